"""Drawing the drill: frames, windows, videos and GIFs.

| module | holds |
|---|---|
| :mod:`~soccer_drill.rendering.draw` | ``Renderer``: pygame drawing of one state, off-screen or in a window |
| :mod:`~soccer_drill.rendering.screen` | what each ``render_mode`` does with every cycle (one frame per cycle, ``render_fps``) |
| :mod:`~soccer_drill.rendering.batch` | ``BatchRenderer``: one off-screen frame per drill of a batch |
| :mod:`~soccer_drill.rendering.video` | ``RecordVideo``, keeping every frame of a holder step |
| :mod:`~soccer_drill.rendering.gif` | GIF writing and the ``soccer-drill-gif`` command |
"""
