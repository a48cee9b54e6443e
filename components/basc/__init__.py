"""The ``basc`` component: the 2015 Two!Ears example reader of the ``bass`` Audio port."""

from ._component import Basc, BlockReport, e_noData, e_nomem

__all__ = ["Basc", "BlockReport", "e_noData", "e_nomem"]
