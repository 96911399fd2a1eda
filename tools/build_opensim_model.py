"""Write the shipped OpenSim files of data/opensim/ from exporters.opensim_model (needs ``opensim``).

    python tools/build_opensim_model.py [data/opensim]

Writes ``platypose17.osim`` (the generic model), ``platypose17_scale.xml`` and
``platypose17_ik.xml`` (set-ups for a trial ``markers.trc`` beside them, 0 to 10 s;
edit the times and file names for yours). ``platypose export ... --formats mot`` builds
the same model in memory and runs the same set-ups on each person.
"""

import sys
from pathlib import Path

from platypose.exporters.mot import load_opensim
from platypose.exporters.opensim_model import build_model, ik_tool, scale_tool

out = Path(sys.argv[1] if len(sys.argv) > 1 else "data/opensim")
out.mkdir(parents=True, exist_ok=True)
osim = load_opensim()
build_model(osim).printToXML(str(out / "platypose17.osim"))
times = (0.0, 10.0)
scale_tool(osim, "platypose17.osim", "markers.trc", times, "platypose17_scaled.osim").printToXML(
    str(out / "platypose17_scale.xml")
)
ik = ik_tool(osim, "markers.trc", times, "markers_ik.mot")
ik.set_model_file("platypose17_scaled.osim")
ik.printToXML(str(out / "platypose17_ik.xml"))
print(f"wrote {out}/platypose17.osim, platypose17_scale.xml, platypose17_ik.xml")
