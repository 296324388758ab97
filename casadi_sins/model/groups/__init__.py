"""The parameter groups, one module each: the paper's six (:mod:`.paper`) and the extra groups, each
owning its sensor side, regressor blocks, correction, simulator truth, export fields and natural units
(:mod:`.base`); :mod:`model.registry` lists them.  A new group is its module, one registry line and its
tests."""
