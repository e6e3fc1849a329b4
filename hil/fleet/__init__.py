"""Many flights, and flights flown again: campaigns (scenarios x sweep points x seeds, in
parallel), each case isolated in its own process, the paper's fidelity experiments, and
replaying or verifying recorded sessions.
"""
