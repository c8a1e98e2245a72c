"""What the user asked the viewer to do once, as opposed to what it should be (the settings):
a screenshot, an export, a library reload and the PC pad's requests. The panel, the keys and
scripts write here during the frame; the loop takes them all at once after the UI and hands
each to the one that carries it out (the reload to the library, the pad's to the update, the
captures to the outputs). Never saved, never restored, never a setting a script can ``set``."""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class Requests:
    screenshot: bool = False          # F12 / the panel's button: a time-stamped PNG of the frame
    export: bool = False              # the panel's "Export shot": a new folder
    reload: bool = False              # re-read the shot library (a bad file keeps the old one)
    pad: list = field(default_factory=list)   # app.viewer.padrequests.PadRequest, in the order asked

    def take(self) -> "Requests":
        """Everything asked since the last take; this object starts empty again."""
        taken = Requests(self.screenshot, self.export, self.reload, self.pad)
        self.screenshot = self.export = self.reload = False
        self.pad = []
        return taken
