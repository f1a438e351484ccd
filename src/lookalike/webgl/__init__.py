"""A real-time engine as a judge: our views rendered by three.js (WebGL 2) in headless
Chromium, the model read by three.js's own glTF loader, as a web viewer shows it.

Nothing here runs in the lookalike process but the orchestration: ``node`` drives Chromium
(``puppeteer-core``) over a page served from this package (``page.html``), and the pictures come
back as float32 RGBA. Needs Debian's ``chromium`` and the npm packages of ``package.json``
(``INSTALL_HINT``); ``threejs_available`` says whether they are there. Modules:

- ``three_views``  ``render_threejs``: a glb under our cameras (and, where given, a point
  light in place of the file's own lights), ``[B, H, W, 4]`` linear RGB weighted by coverage
- ``render.js``, ``page.html``  the node and browser sides
"""

from .three_views import INSTALL_HINT, render_threejs, require_threejs, threejs_available

__all__ = ["INSTALL_HINT", "render_threejs", "require_threejs", "threejs_available"]
