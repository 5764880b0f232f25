"""Rays against the scene's triangles: the BVH built on the CPU (:mod:`.bvh`, binned SAH), the
scene's meshes gathered as rays see them (:mod:`.scene`: what is and is not traced; splat clouds
as their Gaussians inside bounding proxies, :mod:`.splat_proxies`), and their
GPU buffers kept per set of meshes within a byte bound (:mod:`.upload`). GLSL: ``lib/bvh.glsl``
(ray-box, ray-triangle, ray-ellipsoid, a Gaussian's peak along a ray) and ``passes/raytrace.glsl`` (traversal, hit surfaces); twins:
:mod:`learned.twins.bvh`.

Imports: :mod:`viewer.cache`, :mod:`viewer.geometry` (the proxies are meshes),
:mod:`viewer.splats` (the clouds' data), :mod:`viewer.scene` (their material); GL objects are
made from the context handed in.
"""
