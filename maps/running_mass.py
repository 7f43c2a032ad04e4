"""Running masses: the evidence records of a line or corner kept combined, so a rebuild recombines nothing.

A map object's *evidence records* are its history but the noise-elimination
records (:data:`NOISE_STAGE`, a line's first): the sonar's reinforcement. Their
running mass is their masses combined by the map's rule in history order,
``(..((r1 + r2) + r3)..) + rn`` (:func:`running_of`). :class:`RunningMasses`
keeps it for the objects whose running mass has been asked for, combining one
record more in when one is folded in: a rebuilt line's mass is then
``first + running`` (:func:`with_running`), one combination however often the
line was reinforced. Under an associative rule (Dempster's, the conjunctive,
Bayes...) that is the history folded record by record,
``(..(first + r1)..) + rn``, up to rounding; under the others (Yager's,
PCR6...) it is what defines the mass of a rebuilt line or corner, which carries
over the records of the objects it replaces (:func:`carried`).

>>> from evidential import Frame
>>> frame = Frame(["real", "noise"])
>>> records = [{"mass": {"real": 0.5, "real|noise": 0.5}}, {"mass": {"real": 0.4, "real|noise": 0.6}}]
>>> running_of(frame, records, "dempster").to_dict(), running_of(frame, [], "dempster")
({'real': 0.7, 'real|noise': 0.3}, None)
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from evidential import Frame, MassFunction, combine

__all__ = ["NOISE_STAGE", "RunningMasses", "carried", "evidence_records", "running_of", "with_running"]

NOISE_STAGE = "noise_elimination"
"""The stage of a line's first record, its noise-elimination evidence (not part of its running mass)."""


def evidence_records(history: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """The evidence records of a history: all but the noise-elimination ones."""
    return [record for record in history if record.get("stage") != NOISE_STAGE]


def running_of(frame: Frame, records: Iterable[dict[str, Any]], rule: str) -> MassFunction | None:
    """The records' masses (``{FOCAL: float}``) combined by ``rule`` in order, ``(..(r1 + r2)..) + rn``;
    None for no records."""
    running = None
    for record in records:
        mass = MassFunction.from_dict(frame, record["mass"], open_world=True)
        running = mass if running is None else combine(running, mass, rule=rule)
    return running


def with_running(mass: MassFunction, running: MassFunction | None, rule: str) -> MassFunction:
    """``mass + running`` by ``rule`` (``mass`` itself where there are no records)."""
    return mass if running is None else combine(mass, running, rule=rule)


class RunningMasses:
    """The running masses of the objects whose running mass is known, by id (None: no evidence records)."""

    def __init__(self) -> None:
        self._known: dict[str, MassFunction | None] = {}

    def get(self, id: str, frame: Frame, history: list[dict[str, Any]], rule: str) -> MassFunction | None:
        """The running mass of ``id``, made from its ``history`` if not known yet."""
        if id not in self._known:
            self._known[id] = running_of(frame, evidence_records(history), rule)
        return self._known[id]

    def keep(self, id: str, running: MassFunction | None) -> None:
        """``id``'s running mass is ``running`` (as the caller has it)."""
        self._known[id] = running

    def fold(self, id: str, mass: MassFunction, record: dict[str, Any], rule: str) -> None:
        """One record more folded into ``id`` (if its running mass is known and the record is evidence)."""
        if id in self._known and record.get("stage") != NOISE_STAGE:
            running = self._known[id]
            self._known[id] = mass if running is None else combine(running, mass, rule=rule)

    def history_set(self, id: str, new: list[dict[str, Any]], old: list[dict[str, Any]]) -> None:
        """``id``'s history is ``new`` instead of ``old``: its running mass is kept if the evidence is the same."""
        if evidence_records(new) != evidence_records(old):
            self._known.pop(id, None)

    def drop(self, id: str) -> None:
        """Forget ``id``'s running mass (the object is gone)."""
        self._known.pop(id, None)

    def clear(self) -> None:
        """Forget every running mass: they are made again from the histories when asked for."""
        self._known.clear()


def carried(
    frame: Frame, replaced: list[tuple[list[dict[str, Any]], MassFunction | None]], rule: str
) -> tuple[list[dict[str, Any]], MassFunction | None]:
    """The sonar records a rebuilt line or corner carries over from the objects it replaces (the history and
    running mass of each): at most one per pose and source (``matched`` first), by pose; and their running
    mass: that of the one replaced object whose evidence records they are, else made from them.

    >>> frame = Frame(["real", "noise"])
    >>> seen = {"stage": "reinforcement", "pose": 0, "source": "sonar", "mass": {"real": 0.5, "real|noise": 0.5}}
    >>> records, running = carried(frame, [([{**seen, "category": "missed"}], None), ([{**seen, "category": "matched"}], None)], "dempster")
    >>> [r["category"] for r in records], running.to_dict()
    (['matched'], {'real': 0.5, 'real|noise': 0.5})
    """
    best: dict[tuple[Any, Any], dict[str, Any]] = {}
    for history, _ in replaced:
        for record in history:
            if record.get("stage") != "reinforcement":
                continue
            key = (record["pose"], record["source"])
            if key not in best or (record["category"] == "matched" and best[key]["category"] != "matched"):
                best[key] = record
    records = [best[k] for k in sorted(best, key=lambda k: (k[0], str(k[1])))]
    if len(replaced) == 1 and records == evidence_records(replaced[0][0]):
        return records, replaced[0][1]
    return records, running_of(frame, records, rule)
