"""Live view and steering of a run in Foxglove (docs/live.md).

``topics``: which recorded topics are served and how often; ``server``: the foxglove-sdk
WebSocket server beside the recorder (it mirrors what the recorder writes); ``steer``: the
bench's side of the app's commands (pause, resume, step, speed, fault injection);
``options``: the command-line options of ``hil run --live`` and ``hil devices --live``.
"""

