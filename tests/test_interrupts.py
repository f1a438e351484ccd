"""Ctrl-C and SIGTERM held until a loop's step ends (``lookalike.interrupts``)."""

from __future__ import annotations

import os
import signal

import pytest

from lookalike.interrupts import BetweenSteps


@pytest.fixture
def recorded_sigterm():
    """SIGTERM recorded into a list instead of ending the tests."""
    seen: list[int] = []

    def record(number, frame):
        seen.append(number)

    previous = signal.signal(signal.SIGTERM, record)
    yield seen, record
    signal.signal(signal.SIGTERM, previous)


def test_a_signal_waits_for_deliver_and_reaches_the_handler_from_before(recorded_sigterm):
    seen, record = recorded_sigterm
    with BetweenSteps() as stops:
        os.kill(os.getpid(), signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGTERM)
        assert seen == [] and stops.held == [signal.SIGTERM, signal.SIGTERM]
        stops.deliver()
        assert seen == [signal.SIGTERM]                  # once: the second one was the same request
        stops.deliver()
        assert seen == [signal.SIGTERM]
    assert signal.getsignal(signal.SIGTERM) is record


def test_ctrl_c_raises_keyboard_interrupt_at_deliver_and_on_leaving():
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with BetweenSteps() as stops:
            os.kill(os.getpid(), signal.SIGINT)
            with pytest.raises(KeyboardInterrupt):
                stops.deliver()
        with pytest.raises(KeyboardInterrupt), BetweenSteps():   # held when leaving: delivered then
            os.kill(os.getpid(), signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)


def test_leaving_on_an_error_keeps_the_error(recorded_sigterm):
    seen, _ = recorded_sigterm
    with pytest.raises(ValueError), BetweenSteps():
        os.kill(os.getpid(), signal.SIGTERM)
        raise ValueError("the step failed")
    assert seen == []
