"""The muscles' force limit: the bending moment a module's servos may give, at most what its muscles can.

The joint servos (:mod:`srs_ros.sim.model`) reach any shape the skin allows, with whatever moment it takes; the
real module's three extending McKibben muscles give a bounded force at a bounded distance from its axis. With
``servo.bend_moment_limit_nm`` > 0 every hinge servo is force-limited so that the moment vector of a node's two
hinges (about x and y) is at most that limit times the highest pressure of the modules it joins over the robot's
``max_pressure_bar``: the limit grows with the pressure, as the muscles' force does. A module's hinges are in
series, so each carries the module's whole moment: the limit is per module and per hinge alike.

A clamped MuJoCo position servo loses its damping term too (``kv`` is part of the actuator force), and the skin's
spring then rings undamped: the servo's damping is moved onto the joint (implicit, never clamped) when the limit is
on (:func:`srs_ros.sim.model.build_spec`). The circular cap is set once per control period, from the servo's moment
without the limit at that instant (its direction changes little within 10 ms); the x and y ranges then bound the
vector to the circle. Why it is here: docs/studies/simulation.md, "The muscles' moment limit" (issue 19).
"""

from __future__ import annotations

import numpy as np


class BendMomentLimit:
    """Sets the hinge servos' force ranges each control period (a no-op object when the limit is 0)."""

    def __init__(self, model, layout, limit_nm: float, module_count: int, max_pressure_bar: float):
        self.limit_nm = float(limit_nm)
        self.enabled = self.limit_nm > 0.0 and layout.hinge_actuator.size > 0
        if not self.enabled:
            return
        self._model = model
        self._ids = layout.hinge_actuator                               # (N - 1, 2) x and y servos per node
        trn = model.actuator_trnid[self._ids, 0]
        self._qpos = model.jnt_qposadr[trn]
        self._act = model.actuator_actadr[self._ids] + model.actuator_actnum[self._ids] - 1
        self._kp = model.actuator_gainprm[self._ids, 0]
        n, count = layout.segments_per_module, layout.segment_count
        nodes = np.arange(1, count)                                     # node k joins segments k - 1 and k
        self._modules = np.stack([(nodes - 1) // n, np.minimum(nodes // n, module_count - 1)], axis=1)
        self._module_count = int(module_count)
        self._per_bar = self.limit_nm / float(max_pressure_bar)

    def update(self, data, pressure_bar: np.ndarray) -> None:
        """Set each node's x and y ranges: its moment vector at most the limit at the pressures given."""
        if not self.enabled:
            return
        module_bar = np.clip(np.asarray(pressure_bar, dtype=np.float64).reshape(self._module_count, -1), 0.0, None)
        limit = self._per_bar * module_bar.max(axis=1)[self._modules].max(axis=1)         # (N - 1,) N m
        moment = self._kp * (data.act[self._act] - data.qpos[self._qpos])                  # (N - 1, 2) unlimited
        size = np.sqrt(np.einsum("ij,ij->i", moment, moment))
        over = size > limit
        ranges = np.where(over[:, None], np.abs(moment) * (limit / np.maximum(size, 1e-12))[:, None], limit[:, None])
        ranges = np.maximum(ranges, 1e-9)                             # MuJoCo wants lower < upper
        self._model.actuator_forcerange[self._ids, 0] = -ranges
        self._model.actuator_forcerange[self._ids, 1] = ranges
