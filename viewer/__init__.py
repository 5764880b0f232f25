"""The relighting workbench runtime: headless deferred rendering with moderngl (no torch)."""
__version__ = "0.1.0"
