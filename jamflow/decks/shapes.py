"""The jam deck of each shape kind: ``JAM_DECKS[kind](path, start, settings, out=...)`` writes the
deck and its start data file (``decks.jam.emit_deck``, ``decks.ellipsoids.emit_deck``); a kind
without an entry has no deck."""

from __future__ import annotations

from jamflow.decks.ellipsoids import emit_deck as emit_ellipsoid_deck
from jamflow.decks.jam import emit_deck

JAM_DECKS = {"sphere": emit_deck, "ellipsoid": emit_ellipsoid_deck}  #: shape kind -> its jam deck writer
