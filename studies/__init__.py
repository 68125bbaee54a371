"""Studies built on the FE core: one run into a run directory (rundir), sweeps, the CEA of
steady sliding (flutter_fe), FE against the reduced model (verification), the reduced transient."""
