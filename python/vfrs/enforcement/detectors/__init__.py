"""The contact detectors, one module each; :data:`vfrs.enforcement.DETECTORS` loads them all."""
