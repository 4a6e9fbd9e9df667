"""The dynamic contact schemes, one module each; :data:`vfrs.enforcement.SCHEMES` loads them all."""
