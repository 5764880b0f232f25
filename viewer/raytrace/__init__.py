"""Rays against the scene's triangles: the BVH built on the CPU (:mod:`.bvh`, binned SAH), the
scene's meshes gathered as rays see them (:mod:`.scene`: what is and is not traced), and their
GPU buffers kept per set of meshes within a byte bound (:mod:`.upload`). GLSL: ``lib/bvh.glsl``
(ray-box, ray-triangle) and ``passes/raytrace.glsl`` (traversal, hit surfaces); twins:
:mod:`learned.twins.bvh`.

Imports: :mod:`viewer.cache`; the meshes are handed in (:mod:`viewer.geometry`'s), GL objects
are made from the context handed in.
"""
