"""The tract's area functions: the built-in vowels (Story, Titze & Hoffman 1996), the uniform
tube, or the user's (``areas``, ``area_file``), on the equal sections the lattice samples."""

from __future__ import annotations

import numpy as np

#: Built-in area functions (glottis to lips), cm^2 here, and their section length (m): the male
#: speaker's /i/, /ae/, /a/, /u/ of Story, Titze & Hoffman (1996), JASA 100:537-554, Table III
#: (p. 546), equal sections of 0.396825 cm from the glottis (= 350 m/s / (2 x 44.1 kHz)), 42, 42,
#: 44 and 46 of them (the published tract lengths 16.67, 16.67, 17.46, 18.25 cm). Second-hand:
#: the paper was not read here; the values are those of the MATLAB file
#: getMaleVocalTract_Story1996.m (G. Alzamendi 2020), checked equal, section by section, to a
#: transcription of Table III (ctoth/Qlatt, papers/Story_1996_VocalTractAreaFunctionsMRI/notes.md,
#: which stops at section 44: /u/'s last two, 0.41 and 0.86, are the MATLAB file's and a second
#: copy's); the section length is the one the transcription and a parser of the paper's text
#: (lenzo-ka/ipakit, scripts/areafunctions.py) give for Table III's caption, not the MATLAB file's
#: 0.3977 cm. docs/acoustics.md compares their formants with the paper's Table IV.
STORY_1996 = {
    "a": [0.45, 0.20, 0.26, 0.21, 0.32, 0.30, 0.33, 1.05, 1.12, 0.85, 0.63, 0.39, 0.26, 0.28, 0.23,
          0.32, 0.29, 0.28, 0.40, 0.66, 1.20, 1.05, 1.62, 2.09, 2.56, 2.78, 2.86, 3.02, 3.75, 4.60,
          5.09, 6.02, 6.55, 6.29, 6.27, 5.94, 5.28, 4.70, 3.87, 4.13, 4.25, 4.27, 4.69, 5.03],
    "i": [0.33, 0.30, 0.36, 0.34, 0.68, 0.50, 2.43, 3.15, 2.66, 2.49, 3.39, 3.80, 3.78, 4.35, 4.50,
          4.43, 4.68, 4.52, 4.15, 4.09, 3.51, 2.95, 2.03, 1.66, 1.38, 1.05, 0.60, 0.35, 0.32, 0.12,
          0.10, 0.16, 0.25, 0.24, 0.38, 0.28, 0.36, 0.65, 1.58, 2.05, 2.01, 1.58],
    "u": [0.40, 0.38, 0.28, 0.43, 0.55, 1.72, 2.91, 2.88, 2.37, 2.10, 3.63, 5.86, 5.63, 5.43, 4.80,
          4.56, 4.29, 3.63, 3.37, 3.16, 3.31, 3.22, 2.33, 2.07, 2.07, 1.52, 0.74, 0.23, 0.15, 0.22,
          0.22, 0.37, 0.60, 0.76, 0.86, 1.82, 2.35, 2.55, 3.73, 5.47, 4.46, 2.39, 1.10, 0.77, 0.41,
          0.86],
    "ae": [0.22, 0.26, 0.26, 0.16, 0.13, 0.21, 0.83, 1.50, 1.35, 0.99, 0.69, 1.35, 2.32, 2.13, 1.94,
           2.17, 2.85, 3.26, 3.73, 3.80, 3.69, 3.87, 3.68, 3.20, 3.26, 3.29, 3.19, 3.23, 3.23, 3.40,
           3.78, 3.84, 3.98, 4.41, 4.56, 4.79, 4.39, 4.42, 4.23, 4.56, 4.31, 3.94],
}
STORY_1996_SECTION = 0.396825e-2  # m, Table III's caption (second-hand, above)
#: The ``uniform`` tract: 17.5 cm of 3 cm^2 in 44 sections.
UNIFORM = (0.175, 3e-4, 44)
VOWELS = tuple(sorted(STORY_1996)) + ("uniform",)
FORMANT_CEILING = 5000.0  # Hz: the formants reported are below this


def area_function(params) -> tuple:
    """(section lengths (m), areas (m^2)) glottis to lips of the ``[acoustics]`` ``params``:
    ``areas`` (with ``lengths``), ``area_file`` (relative to the working directory), or the
    built-in ``vowel``. Raises ValueError naming the key of a bad one."""
    if params.area_file is not None:
        try:
            data = np.loadtxt(params.area_file, delimiter=",", ndmin=2, comments="#")
        except (OSError, ValueError) as e:
            raise ValueError(f"area_file: cannot read {params.area_file!r} ({e})") from None
        if data.shape[1] != 2:
            raise ValueError(f"area_file: expected two columns (section length m, area m^2), got {data.shape[1]}")
        lengths, areas = data[:, 0], data[:, 1]
        _check_areas(lengths, areas, "area_file")
        return lengths, areas
    if params.areas is not None:
        areas = np.asarray(params.areas, dtype=float)
        if areas.ndim != 1:
            raise ValueError(f"areas: expected a list of numbers, got {params.areas!r}")
        lengths = np.asarray(params.lengths, dtype=float)
        if lengths.ndim > 1 or (lengths.ndim == 1 and len(lengths) != len(areas)):
            raise ValueError(f"lengths: expected one length or one per area ({len(areas)}), got {params.lengths!r}")
        lengths = np.broadcast_to(lengths, areas.shape).copy()
        _check_areas(lengths, areas, "areas")
        return lengths, areas
    if params.vowel == "uniform":
        length, area, n = UNIFORM
        return np.full(n, length / n), np.full(n, area)
    areas = 1e-4 * np.asarray(STORY_1996[params.vowel])
    return np.full(len(areas), STORY_1996_SECTION), areas


def geometry(params) -> tuple:
    """(areas on the tract's equal sections (m^2), the section length (m)) of the
    ``[acoustics]`` ``params``; ValueError naming the key when the tract is shorter than one
    section or its sampling (c / section length) cannot represent it up to
    :data:`FORMANT_CEILING`."""
    lengths, areas = area_function(params)
    total = float(np.sum(lengths))
    dx_wanted = params.section_length if params.section_length is not None else float(np.min(lengths))
    n = int(round(total / dx_wanted))
    if n < 1:
        raise ValueError(f"section_length: the tract ({total:g} m) is shorter than one section ({dx_wanted:g} m)")
    dx = total / n
    fs = params.sound_speed / dx
    if fs < 2.0 * FORMANT_CEILING:
        raise ValueError(f"section_length: sections of {dx * 1e3:.3g} mm sample the tract at {fs:.0f} Hz, which "
                         f"cannot represent it up to {FORMANT_CEILING:g} Hz (sections <= "
                         f"{params.sound_speed / (2 * FORMANT_CEILING) * 1e3:.3g} mm needed)")
    same = len(lengths) == n and np.allclose(lengths, dx, rtol=1e-12, atol=0.0)
    return (np.asarray(areas, dtype=float) if same else resample(lengths, areas, n)), dx


def _check_areas(lengths, areas, key) -> None:
    if len(areas) == 0:
        raise ValueError(f"{key}: no sections")
    if not (np.isfinite(areas).all() and (areas > 0).all()):
        raise ValueError(f"{key}: every area must be > 0 m^2, got {areas.min():g}")
    if not (np.isfinite(lengths).all() and (lengths > 0).all()):
        raise ValueError(f"{key}: every section length must be > 0 m, got {lengths.min():g}")


def resample(lengths, areas, n: int) -> np.ndarray:
    """The area function (piecewise constant over sections of ``lengths``) on ``n`` equal
    sections: each new section's area is the length-weighted mean over it."""
    edges = np.concatenate([[0.0], np.cumsum(lengths)])
    x = np.linspace(0.0, edges[-1], n + 1)
    cum = np.concatenate([[0.0], np.cumsum(np.asarray(lengths) * np.asarray(areas))])  # integral of A dx
    integral = np.interp(x, edges, cum)
    return np.diff(integral) / np.diff(x)

