"""Strapdown navigation on a static base: the one step, the alignment (eq. 14), the error model."""
