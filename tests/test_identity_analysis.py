"""scripts/identity_analysis.py: fragmentations and switches counted from a hand-made matching."""

from __future__ import annotations

from helpers import load_script
from sotmot.scoring import FrameErrors


def test_a_person_on_three_ids_is_two_fragmentations_and_an_id_on_two_people_one_switch():
    script = load_script("identity_analysis")
    errors = FrameErrors()
    # person 0: output ids 1, 1, 2, 3 over frames 1-4; person 1: output id 3 in frames 5-6 (id 3 takes them over)
    errors.identities = {(1, 1): 0, (2, 1): 0, (3, 2): 0, (4, 3): 0, (5, 3): 1, (6, 3): 1}
    assert script.counts(errors) == {"fragmentations": 2, "switches": 1}
    people, tracks = script.lives(errors)
    assert script.changes(people[0]) == [(2, 1, 3, 2), (3, 2, 4, 3)]
    assert script.changes(tracks[3]) == [(4, 0, 5, 1)]
