"""The coordination statechart: its document, checks and SCXML export."""
