"""Finite-element side: Netgen OCC geometry, meshing and NGsolve M/K assembly (the only ngsolve users)."""
