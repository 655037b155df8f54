"""Sessions scored by the pins that fall: real frames (a full rack for the first ball, the
leave where the first ball left it for the second, the 3-6-9 spare line), ten-pin scoring
with bonuses, the tenth frame's bonus balls, the rule in the session ID and the outputs, and a
session resumed from the archive continuing its games exactly.

Pin runs cost ~0.2-0.5 s a ball: the real pins play one game of one bowler (module fixture)
and a resumed copy of it; the frame logic (racks, the tenth frame) is checked with a scripted
pin engine in place of MuJoCo (:func:`scripted`), the spare line on the kernel alone."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bowlrec.archive import Archive
from bowlrec.errors import SceneInputError
from bowlrec.session.records import ShotState, state_from_records
from bowlrec.session.runner import SessionResult, pin_seed, run_session
from bowlrec.session.spec import parse_session, pins_installed
from bowlrec.testing.shots import assert_same_shots

HERE = Path(__file__).parent

needs_pins = pytest.mark.skipif(
    not pins_installed(), reason="MuJoCo not installed (pip install 'bowlrec[pins]')"
)


def _spec(**over: Any) -> Any:
    """One bowler, one game, a robot's scatter, coarse oil grid and sampling; the pins stop at
    2 s and record every 50 ms (small archives)."""
    data: dict[str, Any] = {
        "name": "g",
        "games": 1,
        "seed": 3,
        "grid": {"cell_ft": 3.0, "cell_boards": 1.0},
        "record_dt_s": 0.01,
        "pins": {"max_time_s": 2.0, "record_dt_s": 0.05},
        "bowlers": [{"name": "A", "scene": {}, "scatter": "robot"}],
    }
    data.update(over)
    return parse_session(data)


def hand_score(pinfalls: list[int]) -> list[int]:
    """The running score after each complete frame of a ten-pin game, by hand: a strike is 10
    plus the next two balls, a spare 10 plus the next ball, an open frame its pins."""
    out: list[int] = []
    i, total = 0, 0
    for _ in range(10):
        if i >= len(pinfalls):
            break
        if pinfalls[i] == 10:
            bonus = pinfalls[i + 1 : i + 3]
            if len(bonus) < 2:
                break
            total += 10 + sum(bonus)
            i += 1
            out.append(total)
            continue
        frame = pinfalls[i : i + 2]
        if len(frame) < 2:
            break
        if sum(frame) == 10:
            if i + 2 >= len(pinfalls):
                break
            total += 10 + pinfalls[i + 2]
        else:
            total += sum(frame)
        i += 2
        out.append(total)
    return out


def tenth_frame_balls(pinfalls: list[int]) -> int:
    """How many balls the tenth frame takes, from its own pinfalls: three after a strike or a
    spare in its first two balls, else two."""
    first = pinfalls[0]
    if first == 10 or first + pinfalls[1] == 10:
        return 3
    return 2


# --- the real pins: one game ------------------------------------------------------------------


@pytest.fixture(scope="module")
def game(tmp_path_factory: pytest.TempPathFactory) -> tuple[SessionResult, Archive]:
    if not pins_installed():
        pytest.skip("MuJoCo not installed (pip install 'bowlrec[pins]')")
    archive = Archive(tmp_path_factory.mktemp("games") / "a")
    return run_session(_spec(), archive), archive


@needs_pins
def test_a_game_scores_as_a_hand_check_of_its_rows(game: tuple[SessionResult, Archive]) -> None:
    """The game's score and frame scores are the hand count of the rows' pinfalls; each row's
    running score is the hand count so far; every ball's pins add up (pinfall + standing = the
    pins set) and a second ball is thrown at the pins the first left standing."""
    result, _ = game
    assert result.pins and result.rule.startswith("pins (MuJoCo ")
    rows = result.rows
    falls = [r.pinfall for r in rows]
    assert all(f is not None for f in falls)
    frames = hand_score(falls)  # type: ignore[arg-type]
    (g,) = result.games
    assert (g.bowler, g.game, g.finished) == ("A", 1, True)
    assert list(g.frame_scores) == frames and len(frames) == 10
    assert g.score == frames[-1] == rows[-1].score == result.scores()["A"][0]
    for k, r in enumerate(rows):
        done = hand_score(falls[: k + 1])  # type: ignore[arg-type]
        assert r.score == (done[-1] if done else 0)
    for k, r in enumerate(rows):
        assert r.standing is not None and r.pinfall is not None and r.mark is not None
        full = r.key_pin is None  # a ball at a full rack; else at the previous ball's leave
        set_pins = 10 if full else len(rows[k - 1].standing or ())
        assert r.pinfall + len(r.standing) == set_pins
        if not full:
            assert set(r.standing) <= set(rows[k - 1].standing or ())
            assert rows[k - 1].mark not in ("X", "/") and rows[k - 1].frame == r.frame
        assert r.mark == ("X" if full and not r.standing else "/" if not r.standing else
                          "-" if r.pinfall == 0 else str(r.pinfall))  # fmt: skip
        if full and not r.standing:
            assert r.leave == "strike"
    tenth = [r for r in rows if r.frame == 10]
    assert len(tenth) == tenth_frame_balls([r.pinfall for r in tenth])  # type: ignore[misc]
    assert [r.ball for r in tenth] == list(range(1, len(tenth) + 1))
    marks = "".join(r.mark for r in rows)  # type: ignore[misc]
    assert g.marks.replace(" ", "").replace("|", "") == marks


@needs_pins
def test_each_shot_stores_its_pins_and_the_game_so_far(
    game: tuple[SessionResult, Archive],
) -> None:
    """The archive holds each ball's pinfall, standing pins, where they stand and the score;
    a second ball's pins are set where the first ball's state says they stand, and its pin
    tolerances come from the session's seed and the shot number."""
    result, archive = game
    states: list[ShotState] = []
    for r in result.rows:
        stored = archive.load(r.run_id)
        state = state_from_records(stored.records)
        assert (state.pinfall, state.standing, state.score, state.leave) == (
            r.pinfall,
            r.standing,
            r.score,
            r.leave,
        )
        assert set(state.moved) <= set(state.standing or ())
        pins = stored.scene.options.pin_options
        assert pins is not None and pins.seed == pin_seed(3, r.shot)
        assert pins.hand == "right" and pins.max_time_s == 2.0
        if r.key_pin is not None:  # a spare ball: the leave where it stood
            last = states[-1]
            assert tuple(pins.standing) == last.standing
            assert pins.moved == last.moved
        else:
            assert pins.standing == list(range(1, 11)) and pins.moved == {}
        assert stored.trajectory.pins is not None
        assert stored.trajectory.pins.pinfall == r.pinfall
        states.append(state)


@needs_pins
def test_a_resumed_session_continues_its_games_exactly(
    game: tuple[SessionResult, Archive], tmp_path: Path
) -> None:
    """Stopped after 7 balls (mid-game) and run again, the session reads those back and plays
    the rest: every ball (run ID, pinfall, standing pins, score) and the game equal the
    uninterrupted session's, and the 7 balls simulated on their own equal its first 7."""
    whole, _ = game
    archive = Archive(tmp_path / "a")
    part = run_session(_spec(), archive, max_shots=7)
    (unfinished,) = part.games
    assert not unfinished.finished and unfinished.score == part.rows[-1].score
    again = run_session(_spec(), archive)
    assert (again.resumed, again.simulated) == (7, len(whole.rows) - 7)

    def same(rows: list[Any]) -> list[dict[str, Any]]:
        return [{**r.to_dict(), "simulated": None} for r in rows]

    assert same(part.rows) == same(whole.rows[:7])
    assert same(again.rows) == same(whole.rows)
    assert again.games == whole.games
    np.testing.assert_array_equal(again.final.volume_ul, whole.final.volume_ul)


# --- the spare line -----------------------------------------------------------------------------


@needs_pins
@pytest.mark.parametrize("leave", [(2,), (4,), (5,), (8,), (2, 4, 5), (2, 8)])
def test_a_spare_ball_crosses_the_key_pins_board(leave: tuple[int, ...]) -> None:
    """The 3-6-9 line: the laydown moves as the system says, the target at the arrows is aimed
    so that the ball crosses the key pin's board at the head pin line; with a robot's scatter
    the ball enters within 1.5 boards of it (kernel only: the pins do not change the entry)."""
    from bowlrec.bowling.report import bowler_report
    from bowlrec.core.solver import run_plan
    from bowlrec.pins.spares import spare_target
    from bowlrec.session.runner import _Rack, _Session

    s = _Session(_spec())
    bowler = s.bowlers[0]
    spare = spare_target(leave, "right")
    s.racks[bowler.name] = _Rack(leave, {})
    line = s.line_for(bowler)
    assert line.key_pin == spare.key_pin
    assert line.spare_board == pytest.approx(spare.target_board)
    strike = bowler.scene.delivery
    assert line.scene.delivery.laydown_board == pytest.approx(
        strike.laydown_board + spare.stance_move_boards
    )
    for shot in (2, 3):
        scene = s.shot_scene(bowler, shot, line)
        assert scene.options.pin_options is not None
        assert tuple(scene.options.pin_options.standing) == leave
        traj = run_plan(scene.resolve())
        entry = bowler_report(traj, line.scene.lane, "right").entry_board
        assert entry is not None and abs(entry - spare.target_board) < 1.5


# --- the frame logic, with a scripted pin engine ------------------------------------------------


def scripted(
    monkeypatch: pytest.MonkeyPatch, pinfalls: list[int], seed: int = 3
) -> list[tuple[int, ...]]:
    """Put a scripted pin engine in place of MuJoCo: shot number N knocks down ``pinfalls[N -
    1]`` of the pins set (the lowest numbers first; the shot is found by its pins' seed). The
    list returned collects the pins set for each simulated ball."""
    import bowlrec.api as api
    from bowlrec.pins.leaves import name_leave
    from bowlrec.pins.outcome import PinOutcome

    shots = {pin_seed(seed, n): n for n in range(1, len(pinfalls) + 1)}
    racks: list[tuple[int, ...]] = []

    def fake(plan: Any, traj: Any) -> Any:
        pins = plan.pins
        racks.append(tuple(pins.standing))
        down = pinfalls[shots[pins.seed] - 1]
        standing = tuple(pins.standing[down:])
        leave = name_leave(standing, hand=pins.hand, first_ball=len(pins.standing) == 10)
        out = PinOutcome(pins.standing, standing, leave, pins.hand, (), None, None, None, None)
        return dataclasses.replace(traj, pins=out)

    monkeypatch.setattr(api, "with_pins", fake)
    return racks


FULL = tuple(range(1, 11))


@needs_pins
@pytest.mark.parametrize(
    ("pinfalls", "score", "tenth"),
    [
        ([10] * 12, 300, [FULL, FULL, FULL]),  # strike, strike, strike: a fresh rack each
        ([9, 0] * 9 + [9, 1, 10], 81 + 20, [FULL, (10,), FULL]),  # a spare: one more ball
        ([9, 0] * 9 + [10, 7, 2], 81 + 19, [FULL, FULL, (8, 9, 10)]),  # X then 7: at the leave
        ([9, 0] * 9 + [10, 7, 3], 81 + 20, [FULL, FULL, (8, 9, 10)]),
        ([9, 0] * 9 + [9, 0], 90, [FULL, (10,)]),  # open: no bonus ball
        ([0, 10] * 10 + [10], 100 + 10, [FULL, FULL, FULL]),  # 0 / spares, tenth's bonus X
    ],
)
def test_the_tenth_frame_gives_its_bonus_balls(
    monkeypatch: pytest.MonkeyPatch,
    pinfalls: list[int],
    score: int,
    tenth: list[tuple[int, ...]],
) -> None:
    racks = scripted(monkeypatch, pinfalls)
    result = run_session(_spec(bowlers=[{"name": "A", "scene": {}, "aim": False}]), None)
    assert [r.pinfall for r in result.rows] == pinfalls
    assert result.games[0].score == score == hand_score(pinfalls)[-1]
    frame10 = [r for r in result.rows if r.frame == 10]
    assert len(frame10) == len(tenth) == tenth_frame_balls([r.pinfall for r in frame10])  # type: ignore[misc]
    assert racks[-len(tenth) :] == tenth
    # a spare ball at frames 1-9 is thrown at what the first ball left
    for first, second in zip(result.rows, result.rows[1:], strict=False):
        if second.frame == first.frame < 10 and second.ball == 2:
            assert second.key_pin is not None and first.standing


@needs_pins
def test_bowlers_take_turns_frame_by_frame_and_score_their_own_games(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Two bowlers: A strikes every ball, B leaves the 10 pin and spares it (the spare ball at
    the 10 alone); each bowler's game is their own, the CLI prints each bowler's scores and
    the rule, shots.csv has the pins' columns and games.csv the games."""
    from typer.testing import CliRunner

    from bowlrec.cli import app

    # in order of play: frames 1-9 A's strike, B's 9 and 1; the tenth A's XXX, B's 9/X
    pinfalls = [10, 9, 1] * 9 + [10, 10, 10, 9, 1, 10]
    scripted(monkeypatch, pinfalls)
    bowlers: list[dict[str, Any]] = [
        {"name": n, "scene": {}, "aim": False, "scatter": "robot"} for n in ("A", "B")
    ]
    data = _spec(bowlers=bowlers).model_dump(mode="json")
    session = tmp_path / "s.json"
    session.write_text(json.dumps(data))
    out = tmp_path / "out"
    done = CliRunner().invoke(
        app, ["session", str(session), "-a", str(tmp_path / "a"), "-o", str(out), "--quiet"]
    )
    assert done.exit_code == 0, done.stderr
    assert "scored by pins (MuJoCo " in done.stderr
    assert "A: 300 (series 300)" in done.stderr
    assert "B: 191 (series 191)" in done.stderr
    games = list(csv.DictReader((out / "games.csv").open()))
    assert [(g["bowler"], g["game"], g["score"]) for g in games] == [
        ("A", "1", "300"),
        ("B", "1", "191"),
    ]
    assert games[0]["frame_scores"].split() == [str(30 * k) for k in range(1, 11)]
    shots = list(csv.DictReader((out / "shots.csv").open()))
    assert len(shots) == 12 + 21
    assert [s["bowler"] for s in shots[:4]] == ["A", "B", "B", "A"]
    spare = shots[2]
    assert (spare["pinfall"], spare["standing"], spare["mark"], spare["key_pin"]) == (
        "1",
        "",
        "/",
        "10",
    )
    assert shots[1]["standing"] == "10" and shots[1]["mark"] == "9"


# --- the rule: pins, the pocket window, the session ID ------------------------------------------


def test_without_pins_the_pocket_rule_plays_as_it_always_has() -> None:
    """``pins: false`` is the pocket-window rule of sessions before pins: the committed fixture's
    session (tests/fixtures/archive-v2.1.json, written by it) plays the same shots (to the
    tolerance: :func:`assert_same_shots`), and no game is scored."""
    expected = json.loads((HERE / "fixtures" / "archive-v2.1.json").read_text())
    spec = parse_session({**expected["session"], "pins": False})
    result = run_session(spec, None, max_shots=2)
    assert result.rule == "pocket window (pins: false)" and not result.pins
    rows = [{**r.to_dict(), "simulated": True} for r in result.rows]
    assert_same_shots(rows, expected["shots"])
    assert all(r["pinfall"] is r["mark"] is r["score"] is None for r in rows)
    assert result.games == []


def _no_mujoco(monkeypatch: pytest.MonkeyPatch) -> None:
    import builtins

    real_import = builtins.__import__

    def no_mujoco(name: str, *args: object, **kw: object) -> object:
        if name == "mujoco" or name.startswith("mujoco."):
            raise ImportError("No module named 'mujoco'")
        return real_import(name, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(builtins, "__import__", no_mujoco)


def test_without_the_extra_sessions_keep_the_pocket_rule_and_say_so(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Without MuJoCo a session that does not ask for pins plays the pocket-window rule (the
    same shots and ID as ``pins: false``) and says so on the command line; one that asks for
    them names the extra."""
    from typer.testing import CliRunner

    from bowlrec.cli import app
    from bowlrec.errors import MissingExtraError

    expected = json.loads((HERE / "fixtures" / "archive-v2.1.json").read_text())
    off = parse_session({**expected["session"], "pins": False})
    _no_mujoco(monkeypatch)
    spec = parse_session(expected["session"])
    assert spec.pin_rule() is None
    assert spec.rule() == "pocket window (pins extra not installed)"
    assert spec.session_id() == off.session_id()
    result = run_session(spec, None, max_shots=2)
    assert result.rule == "pocket window (pins extra not installed)"
    assert_same_shots([r.to_dict() for r in result.rows], expected["shots"])
    with pytest.raises(MissingExtraError, match=r"pip install 'bowlrec\[pins\]'"):
        run_session(parse_session({**expected["session"], "pins": True}), None, max_shots=1)
    session = tmp_path / "s.json"
    session.write_text(json.dumps(expected["session"]))
    done = CliRunner().invoke(
        app,
        ["session", str(session), "-a", str(tmp_path / "a"), "-o", str(tmp_path / "out")]
        + ["--max-shots", "2", "-q"],
    )
    assert done.exit_code == 0, done.stderr
    assert "scored by pocket window (pins extra not installed)" in done.stderr


@needs_pins
def test_the_rule_enters_the_session_id_only_with_pins() -> None:
    """The pins' parameters are part of the session's ID (so its shots are other runs than the
    pocket rule's); the pocket rule adds nothing (the ID a session had before pins); ``true``,
    an empty mapping and the default (with MuJoCo) are the same rule."""
    base = _spec(pins=False)
    ids = {
        p: _spec(pins=v).session_id() for p, v in [("true", True), ("empty", {}), ("none", None)]
    }
    assert len(set(ids.values())) == 1 and ids["true"] != base.session_id()
    assert _spec(pins={"max_time_s": 2.0}).session_id() not in (ids["true"], base.session_id())


@pytest.mark.parametrize("field", ["standing", "moved", "seed", "hand"])
def test_the_session_sets_the_pins_of_each_ball_itself(field: str) -> None:
    value = {"standing": [1, 2], "moved": {}, "seed": 1, "hand": "left"}[field]
    with pytest.raises(SceneInputError) as err:
        _spec(pins={field: value})
    message = str(err.value)
    assert "\n" not in message and f"{field} is set per ball by the session" in message


def test_a_shot_state_without_pins_reads_with_defaults() -> None:
    """A state written before sessions had pins (or by the pocket rule) reads with no pins; a
    state with pins round-trips exactly, and the pocket rule's state JSON has no pins' keys."""
    from bowlrec.bowling.oil_transfer import TransferLedger

    ledger = TransferLedger(1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0)
    old = ShotState("s", 1, 1, 1, 1, "A", {"A": 1.5}, ledger)
    text = old.to_json()
    assert b"pinfall" not in text
    back = ShotState.from_json(text)
    assert back == old and back.pinfall is None and back.moved == {}
    new = dataclasses.replace(
        old, pinfall=7, standing=(4, 7, 10), moved={4: (0.01, -0.002)}, leave="4-7-10", score=7
    )
    assert ShotState.from_json(new.to_json()) == new
