"""One creep mechanism: when a minimisation creeps (its max force below a threshold, yet not
converged), a strategy steps the configuration between the minimiser's windows
(``minimize.rules.minimize`` asks ``due`` after every window and calls ``step``).

A ``Creep`` is a trigger and a strategy. The trigger (``CreepTrigger``) says when: after
``after`` iterations, once or every ``every`` iterations, while the max force is below
``creep_force`` (``CREEP_FORCE``, 1e-9 eps/diameter; the rigid bodies' polish from 1e-6). The
strategy takes the step with its own model and line search and returns how many steps it kept:
``polish.PolishSteps`` (Gauss-Newton active-set steps with Armijo backtracking on the exact
energy; disks/spheres and rigid bodies, linear spring), ``soft_modes.SoftModeSteps`` (a Newton
step along the softest modes of the dynamical matrix, the best of a few lengths; any shape) or
``newton.NewtonSteps`` (Newton-Krylov relaxation to the force tolerance; disks/spheres, linear
spring). A trigger with an ``after`` that is not aligned ends the window there (``until_due``).
Which strategy and trigger pay for which scene was measured: ``rules._creep_method``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from jamflow.minimize.settings import CREEP_FORCE


@dataclass
class CreepTrigger:
    """When a creep step is due (forces in eps/diameter, iterations of the minimisation)."""

    after: int  #: iterations before the first attempt
    every: int | None = None  #: iterations between attempts; None: once per minimisation
    creep_force: float = CREEP_FORCE  #: max force below which a minimisation counts as creeping
    aligned: bool = False  #: attempts only at multiples of ``after`` (the polish's measured form)
    attempts: int = 0  #: attempts made so far
    next_at: int = 0  #: the iteration from which the next attempt may run

    def due(self, done: int, max_force: float) -> bool:
        """Whether an attempt is due after ``done`` iterations at this max force (eps / diameter)."""
        if max_force >= self.creep_force:
            return False
        if self.attempts:
            if self.every is None or done < self.next_at:
                return False
        elif not self.aligned and done < self.after:
            return False
        return done % self.after == 0 if self.aligned else True

    def until_due(self, done: int) -> int | None:
        """Iterations from ``done`` to the next point where the trigger may be due (a window should
        end there), or None where the window's own length decides."""
        if self.aligned:
            return None
        if not self.attempts:
            return max(self.after - done, 1)
        if self.every is None:
            return None
        return max(self.next_at - done, 1)

    def fired(self, done: int) -> None:
        """Record an attempt made after ``done`` iterations."""
        self.attempts += 1
        self.next_at = done + (self.every or 0)


class CreepStrategy(Protocol):
    def attempt(self, engine, attempt: int, done: int) -> int:
        """Step the engine's configuration; the number of steps kept (0: it is as before)."""


@dataclass
class Creep:
    """The creep method of one minimisation: its trigger, its strategy, the steps kept."""

    trigger: CreepTrigger  #: when an attempt is due
    strategy: CreepStrategy  #: what an attempt does to the configuration
    accepted: int = 0  #: steps kept so far

    def due(self, done: int, max_force: float) -> bool:
        """The trigger's ``due``."""
        return self.trigger.due(done, max_force)

    def step(self, engine, done: int) -> bool:
        """One attempt; True if a step was kept (the configuration changed)."""
        self.trigger.fired(done)
        kept = self.strategy.attempt(engine, self.trigger.attempts, done)
        self.accepted += kept
        return kept > 0
