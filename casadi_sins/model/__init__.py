"""The sensor output model: its parameters (one registry), eq. 1 and its inverse, the noise model."""
