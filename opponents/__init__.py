"""Scripted defending teams for soccer_drill, registered as ``soccer_drill.opponents`` plugins."""
