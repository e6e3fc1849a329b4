"""What a run or its log says: the trace (whole or streamed), the scenario's criteria, the
400 Hz loop's timing, the summary table and the plots.

Nothing here starts a process or opens a port: these modules read a run's signals, online
while it flies or afterwards from its MCAP log.
"""
