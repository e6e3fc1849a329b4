"""ESC model: servo pulse width -> throttle command, with arming, frame latching and signal loss."""

from emulators.esc.esc import Esc, EscArmed, EscDesync, EscDisarmed, EscState
from emulators.esc.params import EscParams

__all__ = ["Esc", "EscArmed", "EscDesync", "EscDisarmed", "EscParams", "EscState"]
