"""Exported neural shaders, torch-free: the weights file, its GLSL, its GL data, bench kernels.

One module per job:

============ ======================================================================================
module       job
============ ======================================================================================
``format``   the weights file (safetensors keys, metadata), for reading (validation, one-line
             errors naming the file) and for writing (``learned.export``);
             :func:`checkpoint_hash`, :func:`default_weights`
``contract`` the networks' input / output contract: student and teacher inputs, output forms,
             the architecture each kind must have (:func:`expected_networks`)
``glsl``     GLSL generation: ``generated/neural_<kind>.glsl`` for each weight storage
             (:data:`WEIGHT_STORAGES`)
``network``  :func:`load_network` (a validated file with its generated code, cached) and the
             network a lighting pass of a neural model needs (:func:`virtual_files`)
``upload``   :class:`NeuralWeights`: the buffer or texture a storage reads
``kernels``  compute kernels for the MLP alone (``shaders/passes/neural_student.comp``,
             :func:`mlp_kernel`): the ``neural:network`` parity check and the benches
``shadow_net`` the neural shadow estimator's weights file (its own format and version), its
             layer plan, receptive field and weight packing for ``passes/shadow_net_conv.comp``
             (imported as ``viewer.neural.shadow_net``; its names are not re-exported here)
============ ======================================================================================

Every name below is importable from ``viewer.neural`` itself.

Imports: :mod:`viewer.errors`, :mod:`viewer.cache`; never torch.
"""
from .contract import (DEFAULT_FEATURES, DEFAULT_LIGHT_INPUT, DEFAULT_OUTPUT, INDIRECT_HIDDEN,
                       STUDENT_ALL_INPUTS, STUDENT_FEATURES, STUDENT_INDIRECT, STUDENT_INPUTS,
                       STUDENT_OUTPUTS, STUDENT_SSAO_FEATURES, TEACHER_INPUTS, expected_networks, teacher_inputs)
from .format import (FORMAT, FORMAT_VERSION, KINDS, MODEL_KINDS, TENSOR_PARTS, NetworkFile,
                     WeightsError, checkpoint_hash, default_weights, read_weights, tensor_name)
from .glsl import (UBO_MIN_MAX_BYTES, WEIGHT_BINDINGS, WEIGHT_STORAGES, WEIGHT_TEXTURE_WIDTH,
                   NetworkCode, generate_glsl)
from .kernels import STUDENT_KERNEL, STUDENT_KERNEL_ENTRY, STUDENT_KERNEL_GROUP, mlp_kernel
from .network import (Network, learns_indirect, load_network, model_network, needs_env_visibility,
                      reads_occlusion, reads_visibility, required_settings, shades_sun, virtual_files)
from .upload import NeuralWeights

__all__ = [
    # contract, format
    "DEFAULT_FEATURES", "DEFAULT_OUTPUT", "FORMAT", "FORMAT_VERSION", "INDIRECT_HIDDEN", "KINDS", "MODEL_KINDS",
    "STUDENT_ALL_INPUTS", "STUDENT_FEATURES", "STUDENT_INDIRECT", "STUDENT_INPUTS", "STUDENT_OUTPUTS", "STUDENT_SSAO_FEATURES", "TEACHER_INPUTS", "TENSOR_PARTS",
    "DEFAULT_LIGHT_INPUT", "NetworkFile", "WeightsError", "checkpoint_hash", "default_weights",
    "expected_networks", "read_weights", "teacher_inputs", "tensor_name",
    # glsl
    "UBO_MIN_MAX_BYTES", "WEIGHT_BINDINGS", "WEIGHT_STORAGES", "WEIGHT_TEXTURE_WIDTH",
    "NetworkCode", "generate_glsl",
    # kernels
    "STUDENT_KERNEL", "STUDENT_KERNEL_ENTRY", "STUDENT_KERNEL_GROUP", "mlp_kernel",
    # network
    "Network", "learns_indirect", "load_network", "model_network", "needs_env_visibility",
    "reads_occlusion", "reads_visibility", "required_settings",
    "shades_sun", "virtual_files",
    # upload
    "NeuralWeights",
]
