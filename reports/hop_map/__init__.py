"""The hop map: the exact regime and every engine's verdict over a grid of scenes.

``spec`` (the map's axes and settings, map.toml), ``stages`` (the two stages of runs into one
results folder), ``table`` (reading a map folder, agreement per engine and regime).
"""
