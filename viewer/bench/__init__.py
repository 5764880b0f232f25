"""`relight bench`: frame time and error of every shading model and its knobs (see viewer/bench/run.py)."""
