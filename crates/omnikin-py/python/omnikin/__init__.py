"""omnikin: kinematics, planning and simulation of omnidirectional wheeled robots."""

from omnikin._native import Robot, __version__

__all__ = ["Robot", "__version__"]
