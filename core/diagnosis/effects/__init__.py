"""The diagnosable effects, one module each; importing this package registers them all in
:data:`core.diagnosis.registry.EFFECTS`, in the order below: the order they are tried in
(and listed in reports), so the imports are not sorted.

Each module holds its effect's candidate search and one
:func:`~core.diagnosis.registry.register` call declaring everything else about it (see
:mod:`core.diagnosis.registry`).
"""
# isort: skip_file

from . import delay  # noqa: F401
from . import lag  # noqa: F401
from . import resonance  # noqa: F401
from . import rate  # noqa: F401
from . import creep  # noqa: F401
from . import drift  # noqa: F401
from . import asymmetry  # noqa: F401
from . import offset  # noqa: F401
from . import initial_memory  # noqa: F401
from . import saturation  # noqa: F401
from . import dead_zone  # noqa: F401
