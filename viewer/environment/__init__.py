"""HDR environments and everything derived from them.

* :mod:`.maps` — loading equirect files and making procedural skies (numpy);
* :mod:`.sun` — compact-light extraction (the sun, a studio's lamps) from a map;
* :mod:`.ibl`, :mod:`.ibl_core`, :mod:`.ibl_build`, :mod:`.prefilter`, :mod:`.irradiance` —
  split-sum IBL: prefiltered radiance, SH / irradiance, DFG LUTs (GPU compute passes);
* :mod:`.sampling` — importance-sampling tables (the CDFs ``ggx_mc`` and the path tracer draw from);
* :mod:`.store`, :mod:`.entry` — every environment a renderer holds, bounded in memory;
  :mod:`.disk_cache` — the on-disk cache of that precomputation.

Imports: :mod:`viewer.errors`, :mod:`viewer.imageio`, :mod:`viewer.cache`, :mod:`viewer.geometry`
(sRGB decoding); GL programs are handed in. Never the scene, passes or the frame graph.
"""
