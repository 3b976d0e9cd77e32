"""Long renders and render farms (issue #11): time budgets, checkpoints and resume, merging
renders, and passes spread over Dask workers. Every path adds the same float32 chunk read-backs in
pass order (accumulate.py), which is what makes them bit-identical to one uninterrupted render."""
