"""The contact methods, one module each; :data:`vfrs.enforcement.METHODS` loads them all."""
