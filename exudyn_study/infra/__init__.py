"""Infrastructure shared by every package: the on-disk cache, atomic writes, BLAS threads."""
