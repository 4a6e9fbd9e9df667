"""The contact solvers, one module each; :data:`vfrs.enforcement.SOLVERS` loads them all."""
