"""The physics-based neural deferred shader (thesis ch. 4) and its distilled real-time student.

* :mod:`.encoding` - Fourier positional encoding (twin of ``lib/neural.glsl``)
* :mod:`.lighting` - environment resources and per-pixel lighting features in torch
* :mod:`.teacher`  - PBND: diffuse MLP -> [feature, v, h] -> specular MLP, averaged over light samples
* :mod:`.student`  - one evaluation per pixel from pre-integrated lighting (SH + prefiltered)
* :mod:`.shadow`   - the neural shadow estimator UNet of thesis eq. 4.3 (torch only: the two-stage
                     teacher's phase 2)
* :mod:`.shadow_net` - the estimator the viewer runs (``[render] shadow_net``): a 5-level U-Net
                     built from the twins of its GLSL passes, saved in the viewer's format
"""
