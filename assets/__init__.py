"""Built-in data produced by the project's own code (demo scenes, shipped weights)."""
from pathlib import Path

ASSET_ROOT = Path(__file__).resolve().parent
