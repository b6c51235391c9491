"""Sample preparation (paper §2.4).  Containers are here; granulometry, the wire random walk
(Eq. 16-17), the geometric deposit and relaxation come with the sample-preparation issue."""
from .containers import Box, Cylinder, Sphere, TorusCell

__all__ = ["Box", "Cylinder", "Sphere", "TorusCell"]
