"""The vocal tract: a wave-reflection analog driven by the glottal flow, the ``[acoustics]`` effect.

The supraglottal tract (and, optionally, a subglottal one) is a chain of N cylindrical sections
of equal length dx; plane pressure waves cross one section per sample, so the tract is sampled
at ``fs = c / dx`` (Kelly-Lochbaum lattice). At a junction of areas A_k, A_k+1 the waves scatter
with r = (A_k - A_k+1) / (A_k + A_k+1) (pressure and volume velocity continuous); each pass
through a section multiplies a wave by a frequency-independent attenuation exp(-sigma_k dx)
(``losses``), and yielding walls take volume velocity at the junctions (``wall_model``); a
closed side branch, the piriform sinuses, joins one junction as a third port (``piriform``).
At the lips a piston in a baffle (R and L in parallel, trapezoidal in time)
radiates; at the glottis the flow U through the glottal area A_g obeys

    rho U |U| / (2 A_g^2) = p_sub - p_sup,   p_sup = 2 b + Z_1 U,   p_sub = P_lung (or 2 f_s - Z_s U)

(b: the backward wave arriving from the tract, Z_1 = rho c / A_1; with a subglottal tract f_s
is its wave arriving from below), solved in closed form each sample; with ``coupling =
"interactive"`` the jet term is (1 - k_r) rho U|U| / (2 A_g^2), k_r = 2 x (1 - x), x = A_g / A_1
(the pressure recovery), and a flow model's losses join it (docs/acoustics.md). The radiated pressure at
``distance`` r is that of a simple source, p = rho / (4 pi r) dU_lips/dt.

The package: :mod:`~vfrs.acoustics.vowels` (the area functions), :mod:`~vfrs.acoustics.tract` (the
lattice, its walls and side branch), :mod:`~vfrs.acoustics.effect` (the registered ``[acoustics]``
effect, and how the tract keeps step with the structure), :mod:`~vfrs.acoustics.voice` (the WAV
and the spectrum), :mod:`~vfrs.acoustics.figures` (the voice's figures for ``vfrs plot``). The
air's density is the [flow] effect's (``[flow] density``), which the tract takes through its
port (:class:`vfrs.flow.GlottisPort`).

See docs/acoustics.md for the model, its limits and what was measured.
"""

from .effect import Acoustics, acoustic_measures
from .tract import Tract, build_tract
from .vowels import STORY_1996, VOWELS, area_function, geometry

__all__ = ["Acoustics", "STORY_1996", "Tract", "VOWELS", "acoustic_measures", "area_function", "build_tract",
           "geometry"]
