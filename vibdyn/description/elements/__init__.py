"""Force elements, one kind per module (see :mod:`.base` for the protocol every kind follows).

Importing this package registers every kind in :data:`KINDS` (table name -> class), in the order groups
are compiled and scene files are read and written: supports first (springs and dampers attach to them).
A new kind is one new module here plus its import line below.
"""

from ...model.groups import ForceGroup, Group
from ...model.points import Kinematics, cross, point_set
from .base import KINDS, WORLD, ElementKind, attachment

# the order below is the registration order of KINDS (see above): not alphabetical
# isort: off
from .support import Support
from .spring import Spring
from .damper import Damper
from .body_force import BodyForce, vector_or_callable
from .joint_spring import JointSpring
from .joint_damper import JointDamper
from .joint_force import JointForce, joint_force_value
from .cubic_joint_spring import CubicJointSpring
from .drive import Drive
from .bearing import Bearing
from .unbalance import Unbalance
# isort: on

__all__ = ["KINDS", "WORLD", "ElementKind", "ForceGroup", "Group", "Kinematics", "attachment", "cross", "point_set",
           "Support", "Spring", "Damper", "BodyForce", "JointSpring", "JointDamper", "JointForce",
           "CubicJointSpring", "Drive", "Bearing", "Unbalance", "vector_or_callable", "joint_force_value"]
