"""Torch side of the Gaussian splats: the differentiable twin rasterizer (:mod:`.rasterize`) and
material/light decomposition (:mod:`.decompose`)."""
