"""Travelling waves solved in the wave's frame (``stickslip travel``; docs/travelling_waves.md).

``wave_from_run(run_dir)`` solves the wave a finished run computes (the transient's own
discrete wave at the run's step) and compares it with the run; ``NotRigidWave`` is raised
when the run's end state is not a rigidly travelling wave.
"""

from stickslip.studies.travel.from_run import NotRigidWave, wave_from_run, wave_stability

__all__ = ["NotRigidWave", "wave_from_run", "wave_stability"]
