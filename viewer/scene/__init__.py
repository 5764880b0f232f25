"""The scene: what is rendered, as frozen dataclasses, and everything that makes or checks one.

* :mod:`.description` — the dataclasses and ``load_scene`` (TOML -> :class:`Scene`);
  :mod:`.files` writes them back; :mod:`.checks` validates every table and key (a ``[render]``
  key's check lives there); :mod:`.settings` groups the ``[render]`` table;
* :mod:`.material`, :mod:`.camera` — a material's and a camera's parameters;
* :mod:`.assets`, :mod:`.framing`, :mod:`.orientation`, :mod:`.bounds` — scenes made for asset
  files: their up axis, a camera framed on their bounds.

Imports: :mod:`viewer.errors`, :mod:`viewer.models`, :mod:`viewer.environment` (maps),
:mod:`viewer.lighting` (light tables), :mod:`viewer.geometry` and :mod:`viewer.splats` loaders,
:mod:`viewer.neural` (a weights file's check); never GL contexts or passes.
"""
