"""`relight bench`: frame time and error of every shading model and its knobs (see relight/bench/run.py)."""
