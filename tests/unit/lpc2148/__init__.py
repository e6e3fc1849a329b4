"""Tests of the LPC2148 peripheral models (emulators/lpc2148)."""
