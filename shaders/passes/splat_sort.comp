// splat_sort.comp - one compare-exchange step (k, j) of a bitonic sort over a power-of-two count:
// orders (key, index) pairs by decreasing key (view depth: back to front), ties by increasing
// index, so the result equals a stable CPU argsort. Padding entries carry key -inf.
layout(local_size_x = 256) in;

layout(std430, binding = 0) buffer Keys { float keys[]; };
layout(std430, binding = 1) buffer Order { uint order[]; };

uniform uint u_k;      // size of the bitonic sequences being merged
uniform uint u_j;      // compare distance
uniform uint u_count;  // padded (power-of-two) count

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint l = i ^ u_j;
    if (i >= u_count || l <= i) {
        return;
    }
    float ki = keys[i];
    float kl = keys[l];
    uint oi = order[i];
    uint ol = order[l];
    bool i_first = ki > kl || (ki == kl && oi < ol);
    bool ascending = (i & u_k) == 0u;
    if (ascending != i_first) {
        keys[i] = kl;
        keys[l] = ki;
        order[i] = ol;
        order[l] = oi;
    }
}
