"""Lights and where their shadows are drawn from.

* :mod:`.lights` — punctual lights (directional, point, spot) in glTF's units;
* :mod:`.tables` — the scene file's ``[[lights]]`` tables and glTF's ``KHR_lights_punctual``;
* :mod:`.shadow_frames` — a shadowing light's map: its view, projection and extent;
* :mod:`.cascades` — cascaded shadow maps for directional lights over large scenes.

Imports: :mod:`viewer.errors`, :mod:`viewer.scene` (bounds, checks); no GL. The passes that draw
and read the maps are :mod:`viewer.passes.shadow` and :mod:`viewer.graph.shadows`.
"""
