"""Finite-element side: Netgen OCC geometry, meshing and NGsolve M/K assembly (the only ngsolve users)."""


def mesher_version() -> str:
    """Netgen's version string (part of every cached body's recipe: a new mesher may mesh differently)."""
    import netgen

    return getattr(netgen, "__version__", "unknown")
