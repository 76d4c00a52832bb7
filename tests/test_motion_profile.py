"""PathProfile: the Ruckig time law of s ∈ [0, 1] with stop, pause and resume."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from controller.motion.profile import PathProfile, ProfileState

DT = 0.002
V_MAX, A_MAX = 1.0, 2.0
#: Relative tolerance on the speed and acceleration limits.
LIMIT_TOL = 1e-9
#: Rounding allowed on s (monotonicity, never past 1).
S_TOL = 1e-12
MAX_CYCLES = 200_000

RUNNING, STOPPING = ProfileState.RUNNING, ProfileState.STOPPING
PAUSING, PAUSED, DONE = ProfileState.PAUSING, ProfileState.PAUSED, ProfileState.DONE


@dataclass
class Trace:
    """s, ṡ, s̈ and the state after every cycle (s starts with the value before the first)."""

    s: list[float] = field(default_factory=list)
    sd: list[float] = field(default_factory=list)
    sdd: list[float] = field(default_factory=list)
    states: list[ProfileState] = field(default_factory=list)


def step(profile: PathProfile, trace: Trace) -> None:
    profile.step()
    trace.s.append(profile.s)
    trace.sd.append(profile.sd)
    trace.sdd.append(profile.sdd)
    trace.states.append(profile.state)


def run_until(profile: PathProfile, states: set[ProfileState], trace: Trace | None = None) -> Trace:
    """Step until the state is one of ``states``."""
    trace = trace if trace is not None else Trace(s=[profile.s])
    for _ in range(MAX_CYCLES):
        if profile.state in states:
            return trace
        step(profile, trace)
    raise AssertionError(f"still {profile.state} after {MAX_CYCLES} cycles")


def run_cycles(profile: PathProfile, n: int, trace: Trace | None = None) -> Trace:
    trace = trace if trace is not None else Trace(s=[profile.s])
    for _ in range(n):
        step(profile, trace)
    return trace


def cycles_to_finish(v: float, a: float, duration: float | None = None) -> int:
    profile = PathProfile(DT, v, a, duration)
    return len(run_until(profile, {DONE}).states)


def assert_monotone(s: list[float]) -> None:
    drops = [b - a for a, b in itertools.pairwise(s) if b < a - S_TOL]
    assert not drops, f"s went backwards by {min(drops)}"


def assert_slowing_down(sd: list[float]) -> None:
    assert all(b <= a + S_TOL for a, b in itertools.pairwise(sd)), "sped up while braking"


def assert_within_limits(trace: Trace, v: float, a: float) -> None:
    assert max(map(abs, trace.sd), default=0.0) <= v * (1 + LIMIT_TOL)
    assert max(map(abs, trace.sdd), default=0.0) <= a * (1 + LIMIT_TOL)


def paused_midway(v: float = V_MAX, a: float = A_MAX) -> tuple[PathProfile, Trace]:
    """A profile paused in its cruise phase, and the trace up to PAUSED."""
    profile = PathProfile(DT, v, a)
    trace = run_cycles(profile, cycles_to_finish(v, a) // 2)
    profile.pause()
    run_until(profile, {PAUSED}, trace)
    return profile, trace


# ------------------------------------------------------------------------- construction
@pytest.mark.parametrize(
    ("v", "a"), [(0.0, 1.0), (1.0, 0.0), (-1.0, 1.0), (1.0, -0.5), (math.nan, 1.0), (1.0, math.nan)]
)
def test_non_positive_limits_are_rejected(v: float, a: float):
    with pytest.raises(ValueError, match="positive"):
        PathProfile(DT, v, a)


def test_a_new_profile_runs_from_rest_at_zero():
    profile = PathProfile(DT, V_MAX, A_MAX)
    assert profile.state == RUNNING and not profile.finished
    assert (profile.s, profile.sd, profile.sdd) == (0.0, 0.0, 0.0)


# ----------------------------------------------------------------------------- full run
@pytest.mark.parametrize(("v", "a"), [(1.0, 2.0), (0.3, 5.0), (2.0, 0.5), (0.25, 0.25)])
def test_s_rises_monotonically_and_ends_exactly_at_one_at_rest(v: float, a: float):
    profile = PathProfile(DT, v, a)
    trace = run_until(profile, {DONE})
    assert_monotone(trace.s)
    assert all(state == RUNNING for state in trace.states[:-1])
    assert profile.finished
    assert profile.s == 1.0
    assert profile.sd == 0.0 and profile.sdd == 0.0


@pytest.mark.parametrize(("v", "a"), [(1.0, 2.0), (0.3, 5.0), (2.0, 0.5), (0.25, 0.25)])
def test_speed_and_acceleration_stay_within_the_limits(v: float, a: float):
    trace = run_until(PathProfile(DT, v, a), {DONE})
    assert_within_limits(trace, v, a)
    # Time-optimal: the acceleration limit is used.
    assert max(map(abs, trace.sdd)) >= a * 0.999


def test_cruise_runs_at_the_speed_limit():
    trace = run_until(PathProfile(DT, V_MAX, A_MAX), {DONE})
    assert max(trace.sd) == pytest.approx(V_MAX, rel=1e-9)


@pytest.mark.parametrize("duration", [2.0, 3.0, 5.5])
def test_duration_makes_the_motion_last_that_long(duration: float):
    assert cycles_to_finish(V_MAX, A_MAX) * DT < duration  # the limits allow it
    profile = PathProfile(DT, V_MAX, A_MAX, duration)
    trace = run_until(profile, {DONE})
    assert abs(len(trace.states) * DT - duration) <= DT * (1 + 1e-9)
    assert_monotone(trace.s)
    assert_within_limits(trace, V_MAX, A_MAX)
    assert profile.s == pytest.approx(1.0, abs=S_TOL)


def test_duration_shorter_than_the_limits_allow_takes_the_minimum_time():
    fastest = cycles_to_finish(V_MAX, A_MAX)
    assert cycles_to_finish(V_MAX, A_MAX, duration=0.5 * fastest * DT) == fastest


# ----------------------------------------------------------------------------------- stop
def test_stop_midway_decelerates_on_the_path_and_ends_before_the_end():
    profile = PathProfile(DT, V_MAX, A_MAX)
    trace = run_cycles(profile, cycles_to_finish(V_MAX, A_MAX) // 2)
    assert trace.sd[-1] == pytest.approx(V_MAX)  # cruising
    profile.stop()
    assert profile.state == STOPPING
    braking = run_until(profile, {DONE}, Trace(s=[profile.s], sd=[profile.sd]))
    assert all(state == STOPPING for state in braking.states[:-1])
    assert_monotone(braking.s)
    assert_slowing_down(braking.sd)
    assert_within_limits(braking, V_MAX, A_MAX)
    assert min(braking.sdd) <= -A_MAX * 0.999  # at the acceleration limit
    assert profile.state == DONE
    assert profile.sd == 0.0 and profile.sdd == 0.0
    assert profile.s < 1.0


def test_stop_right_at_the_start_ends_at_zero():
    profile = PathProfile(DT, V_MAX, A_MAX)
    profile.stop()
    run_until(profile, {DONE})
    assert profile.s == 0.0


def test_stop_near_the_end_never_overshoots_one():
    total = cycles_to_finish(V_MAX, A_MAX)
    for cycle in range(total // 2, total):
        profile = PathProfile(DT, V_MAX, A_MAX)
        run_cycles(profile, cycle)
        profile.stop()
        trace = run_until(profile, {DONE})
        assert max(trace.s) <= 1.0 + S_TOL, f"stop at cycle {cycle}"
        assert_monotone(trace.s)
        assert_within_limits(trace, V_MAX, A_MAX)
        assert profile.sd == 0.0


def test_pause_and_resume_are_ignored_while_stopping():
    profile = PathProfile(DT, V_MAX, A_MAX)
    run_cycles(profile, 200)
    profile.stop()
    profile.pause()
    assert profile.state == STOPPING
    profile.resume()
    assert profile.state == STOPPING
    run_until(profile, {DONE})
    assert profile.s < 1.0


# ---------------------------------------------------------------------------------- pause
def test_pause_decelerates_on_the_path_then_holds_still():
    profile = PathProfile(DT, V_MAX, A_MAX)
    before = run_cycles(profile, cycles_to_finish(V_MAX, A_MAX) // 2)
    profile.pause()
    assert profile.state == PAUSING
    braking = run_until(profile, {PAUSED}, Trace(s=[before.s[-1]], sd=[before.sd[-1]]))
    assert all(state == PAUSING for state in braking.states[:-1])
    assert_monotone(braking.s)
    assert_slowing_down(braking.sd)
    assert_within_limits(braking, V_MAX, A_MAX)
    assert profile.s < 1.0
    s_paused = profile.s
    held = run_cycles(profile, 2000)
    assert set(held.states) == {PAUSED}
    assert set(held.s) == {s_paused}
    assert set(held.sd) == {0.0} and set(held.sdd) == {0.0}
    assert not profile.finished


def test_resume_after_pause_continues_to_exactly_one():
    profile, trace = paused_midway()
    s_paused = profile.s
    profile.resume()
    assert profile.state == RUNNING
    rest = run_until(profile, {DONE}, Trace(s=[s_paused]))
    assert rest.s[1] >= s_paused
    assert_monotone(trace.s + rest.s)
    assert_within_limits(rest, V_MAX, A_MAX)
    assert profile.s == 1.0 and profile.sd == 0.0


def test_resume_while_pausing_cancels_the_pause():
    profile = PathProfile(DT, V_MAX, A_MAX)
    trace = run_cycles(profile, cycles_to_finish(V_MAX, A_MAX) // 2)
    profile.pause()
    run_cycles(profile, 50, trace)
    assert profile.state == PAUSING
    profile.resume()
    assert profile.state == RUNNING
    run_until(profile, {DONE}, trace)
    assert PAUSED not in trace.states
    assert_monotone(trace.s)
    assert_within_limits(trace, V_MAX, A_MAX)
    assert profile.s == 1.0


def test_stop_while_paused_ends_at_once_where_it_is():
    profile, _ = paused_midway()
    s_paused = profile.s
    profile.stop()
    assert profile.state == DONE and profile.finished
    run_cycles(profile, 10)
    assert profile.s == s_paused and profile.sd == 0.0


def test_stop_while_pausing_ends_without_reaching_the_end():
    profile = PathProfile(DT, V_MAX, A_MAX)
    run_cycles(profile, cycles_to_finish(V_MAX, A_MAX) // 2)
    profile.pause()
    run_cycles(profile, 20)
    profile.stop()
    assert profile.state == STOPPING
    trace = run_until(profile, {DONE})
    assert_monotone(trace.s)
    assert profile.s < 1.0 and profile.sd == 0.0


def test_resume_while_running_changes_nothing():
    plain, resumed = PathProfile(DT, V_MAX, A_MAX), PathProfile(DT, V_MAX, A_MAX)
    a = run_cycles(plain, 300)
    b = run_cycles(resumed, 300)
    resumed.resume()
    assert resumed.state == RUNNING
    run_until(plain, {DONE}, a)
    run_until(resumed, {DONE}, b)
    assert a == b


@pytest.mark.parametrize("command", ["pause", "resume", "stop"])
def test_commands_after_the_end_change_nothing(command: str):
    profile = PathProfile(DT, V_MAX, A_MAX)
    run_until(profile, {DONE})
    getattr(profile, command)()
    assert profile.state == DONE
    trace = run_cycles(profile, 10)
    assert set(trace.s) == {1.0} and set(trace.sd) == {0.0} and set(trace.states) == {DONE}


# ----------------------------------------------------------------------------- property
def expected_state(before: ProfileState, command: str) -> ProfileState:
    """The state right after ``command`` (the documented state machine)."""
    if command == "stop":
        if before == PAUSED:
            return DONE
        return before if before in (DONE, STOPPING) else STOPPING
    if command == "pause":
        return PAUSING if before == RUNNING else before
    return RUNNING if before in (PAUSED, PAUSING) else before  # resume


@settings(deadline=None, max_examples=60)
@given(
    v=st.floats(0.3, 5.0),
    a=st.floats(0.3, 20.0),
    commands=st.lists(
        st.tuples(st.floats(0.0, 1.2), st.sampled_from(["stop", "pause", "resume"])),
        max_size=4,
    ),
)
def test_commands_at_random_cycles_keep_the_invariants(v, a, commands):
    nominal = cycles_to_finish(v, a)
    pending = sorted((int(frac * nominal), command) for frac, command in commands)
    profile = PathProfile(DT, v, a)
    trace = Trace(s=[profile.s])
    stopped = False
    for cycle in range(MAX_CYCLES):
        while pending and pending[0][0] <= cycle:
            command = pending.pop(0)[1]
            before = profile.state
            getattr(profile, command)()
            assert profile.state == expected_state(before, command), (before, command)
            stopped |= command == "stop" and before != DONE
        if not pending and profile.state in (DONE, PAUSED):
            break
        s_before = profile.s
        step(profile, trace)
        if trace.states[-1] == PAUSED and len(trace.states) > 1 and trace.states[-2] == PAUSED:
            assert profile.s == s_before and profile.sd == 0.0 and profile.sdd == 0.0
    if profile.state == PAUSED:  # left paused: it holds, and a resume finishes the path
        s_paused = profile.s
        run_cycles(profile, 100, trace)
        assert trace.s[-1] == s_paused
        profile.resume()
        run_until(profile, {DONE}, trace)
    assert profile.state == DONE
    assert profile.sd == 0.0 and profile.sdd == 0.0
    assert_monotone(trace.s)
    assert_within_limits(trace, v, a)
    assert min(trace.sd) >= -S_TOL
    assert -S_TOL <= min(trace.s) and max(trace.s) <= 1.0 + S_TOL
    if not stopped:
        assert profile.s == 1.0


def test_limits_that_make_ruckig_raise_are_retried_slightly_lower():
    """Ruckig 0.19 raises on these exact values (50 and 200 work)."""
    profile = PathProfile(0.002, 49.99999999999996, 199.9999999999998)
    for _ in range(1000):
        profile.step()
        if profile.finished:
            break
    assert profile.finished and profile.s == 1.0
