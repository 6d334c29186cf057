"""Model against recordings: validation, calibration of constants, missing-physics diagnosis
(candidates, locating the mismatch, held-out selection) and its blind benchmark. All of it runs
on :mod:`vadsim.compare`."""
