"""spherekin: direct kinematics of parallel spherical mechanisms with Bernstein polynomials."""
__version__ = "0.1.0"
