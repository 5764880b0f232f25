"""CPU geometry, no GL: what the G-buffer and shadow passes draw and the ray tracer will trace.

* :mod:`.mesh` — triangle meshes in world space (:class:`~.mesh.Mesh`); :mod:`.loaders` — mesh
  files (glTF, OBJ, PLY, STL, OFF); :mod:`.primitives` — spheres, planes, the material-ball grid;
* :mod:`.imagespace` — image-space G-buffer stacks (FFHQ256-PBR folders, 12-channel EXRs);
* :mod:`.simplify`, :mod:`.solid` — shadow casters' levels of detail and their solid test;
* :mod:`.cache` — every object's geometry, loaded once and kept within a byte bound.

Imports: :mod:`viewer.errors`, :mod:`viewer.cache`, :mod:`viewer.imageio`, :mod:`viewer.gbuffer`,
:mod:`viewer.scene` (object and material specs), :mod:`viewer.lighting` (glTF lights),
:mod:`viewer.splats`.
"""
