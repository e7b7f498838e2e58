"""Drawing the drill: frames, windows, videos and GIFs.

| module | holds |
|---|---|
| :mod:`~soccer_drill.rendering.scene` | ``Scene``, what a frame shows besides the bodies (an environment's render state), and ``FrameStyle``, which parts are drawn |
| :mod:`~soccer_drill.rendering.draw` | ``Renderer``: pygame drawing of one state and its scene, off-screen or in a window |
| :mod:`~soccer_drill.rendering.screen` | what each ``render_mode`` does with every cycle (one frame per cycle, ``render_fps``) |
| :mod:`~soccer_drill.rendering.batch` | ``BatchRenderer``: one off-screen frame per drill of a batch |
| :mod:`~soccer_drill.rendering.video` | ``RecordVideo``, keeping every frame of a holder step |
| :mod:`~soccer_drill.rendering.gif` | GIF writing and the ``soccer-drill-gif`` command |
| :mod:`~soccer_drill.rendering.side_by_side` | policies on the same seeds, one panel each, as a GIF or MP4: ``soccer-drill-side-by-side`` |
| :mod:`~soccer_drill.rendering.play` | the drill played at the keyboard: ``soccer-drill-play`` |
| :mod:`~soccer_drill.rendering.controls` | what the player of ``soccer-drill-play`` controls (``CONTROLS``): the holder's SMDP, or one attacker of the PettingZoo drill |
| :mod:`~soccer_drill.rendering.gallery` | the documentation's GIFs and notebooks regenerated: ``soccer-drill-gallery`` |
"""
