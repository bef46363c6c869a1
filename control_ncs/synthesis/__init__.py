"""Synthesis: one method family for every design specification
(:ref:`theory-synthesis`, :ref:`theory-performance`,
:ref:`theory-links-compose`).

A dispatcher per specification validates its arguments, builds the open
loop (:func:`control_ncs.build`) once and picks a route; the routes never
call a public function:

* :mod:`.passive` — :func:`passivesyn` (strict passivity, any supply's
  level ``η``);
* :mod:`.norms` — :func:`h2syn` and :func:`hinfsyn`;
* routes: the convex programs and the Riccati iteration (:mod:`._routes`
  for passivity, the exact H2/H∞ programs in :mod:`.norms`), and one
  local-search kernel (:mod:`._local`) on exact figures, with the
  objectives of :mod:`._h2` and :mod:`._hinf` and the passivity driver
  :mod:`.refine` (:func:`refine_gain`);
* one result for every design (:mod:`._result`).
"""

from .norms import *  # noqa: F403
from .passive import *  # noqa: F403
from .refine import *  # noqa: F403
from . import norms, passive, refine

__all__ = passive.__all__ + norms.__all__ + refine.__all__
