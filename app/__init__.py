"""Hitpoint's application layer: CLI, window, renderer, panel."""
import os

# Our matrices are small (a shot is ~70 x 107): multithreaded BLAS only adds
# thread start-up and spinning, which cost ~90 ms per SVD on a loaded 2-core
# machine against ~1.4 ms single-threaded. Must be set before numpy loads.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
