"""meshcat commands of a drawn scene, and the viewer's HTML page: meshcat's bundled three.js viewer
(``main.min.js``, inlined for the offline page) with a panel listing the motions (modes with their
frequencies and damping ratios, or a trajectory) to pick from, play and pause.

The page reads its URL fragment: ``#mode=2`` shows the second motion, ``&t=0.5`` stops at 0.5 s of it.
"""

import base64
import html
import importlib.util
import json
from pathlib import Path

import numpy as np

from .drawing import ROOT, three_object

CAMERA = "/Cameras/default/rotated/<object>"


def meshcat_dist():
    """Folder of meshcat's bundled viewer (without importing meshcat)."""
    spec = importlib.util.find_spec("meshcat")
    if spec is None or not spec.submodule_search_locations:
        from ...errors import ModelError

        raise ModelError("the viewer needs meshcat: pip install meshcat")
    return Path(list(spec.submodule_search_locations)[0]) / "viewer" / "dist"


def scene_commands(drawing, q0, view_dir=None):
    """meshcat commands (plain dicts) drawing the scene at q0: objects, their poses, ground grid, camera.

    The scene is shifted so that its centre is the origin the camera orbits about."""
    c, s = drawing.center, drawing.size
    cmds = [{"type": "set_property", "path": "/Axes", "property": "visible", "value": False}]
    grid = np.eye(4)  # meshcat's grid: 20 m wide in the x–y plane, scaled to twice the scene
    k = 2 * s / 20
    grid[:3, :3] *= k
    grid[:3, 3] = (0.0, 0.0, drawing.ground - c[2])
    cmds.append(_transform("/Grid", grid))
    shift = np.eye(4)
    shift[:3, 3] = -c
    cmds.append(_transform(ROOT, shift))
    for item in drawing.items:
        cmds.append({"type": "set_object", "path": f"{ROOT}/{item.node}/{item.name}", "object": three_object(item)})
    for node, M in drawing.poses(q0).items():
        cmds.append(_transform(f"{ROOT}/{node}", M))
    d = np.asarray(view_dir if view_dir is not None else (0.55, -1.0, 0.45), float)
    d = d / np.linalg.norm(d)
    eye = d * 0.5 * s / np.sin(np.radians(30)) * 1.15  # the scene's sphere in a 60° view
    cmds.append({"type": "set_property", "path": CAMERA, "property": "position",
                 "value": [float(eye[0]), float(eye[2]), float(-eye[1])]})  # camera node is rotated: y up
    for prop, value in (("near", 0.01 * s), ("far", 100 * s)):
        cmds.append({"type": "set_property", "path": CAMERA, "property": prop, "value": float(value)})
    return cmds


def plane_normal(displacements):
    """The unit normal of the plane a motion spans ((n × 3) point displacements, m, real or complex): the
    direction its points move least, when they hardly move along it (below 5 % of the largest spread); None
    when they move in every direction. Its sign puts the viewer in front (−y) or above (+z)."""
    D = np.asarray(displacements).reshape(-1, 3)
    if D.size == 0:
        return None
    D = np.vstack([D.real, D.imag])
    C = D.T @ D
    if not np.any(C):
        return None
    w, V = np.linalg.eigh(C)
    if w[0] > 0.05 * w[-1]:  # no plane of motion
        return None
    n = V[:, 0]
    if abs(n[1]) >= max(abs(n[0]), abs(n[2])):
        return n if n[1] <= 0 else -n
    return n if n[2] >= 0 else -n


def view_direction(displacements):
    """A viewing direction across a motion for the 3-D page: along its plane's normal (:func:`plane_normal`)
    raised to an elevation of 12–35° (the page keeps a 3-D view), or None (the usual oblique view) when it
    moves in every direction."""
    n = plane_normal(displacements)
    if n is None:
        return None
    h = np.array([n[0], n[1], 0.0])
    if np.linalg.norm(h) < 0.3:  # motion in a horizontal plane: look from the front, from above
        h = np.array([0.3, -1.0, 0.0])
    h /= np.linalg.norm(h)
    elevation = np.radians(np.clip(np.degrees(np.arcsin(np.clip(n[2], -1, 1))), 12.0, 35.0))
    return h * np.cos(elevation) + np.array([0.0, 0.0, np.sin(elevation)])


def _transform(path, M):
    return {"type": "set_transform", "path": path, "matrix": [float(x) for x in np.asarray(M).T.ravel()]}


def to_json(obj):
    """JSON text of commands; bytes (binary meshes) as {"__b64": ...}, decoded to Uint8Array by the page."""
    def default(o):
        if isinstance(o, (bytes, bytearray)):
            return {"__b64": base64.b64encode(bytes(o)).decode("ascii")}
        if isinstance(o, np.generic):
            return o.item()
        raise TypeError(type(o).__name__)

    return json.dumps(obj, default=default, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")


PANEL_CSS = """
body { margin: 0; font: 13px/1.35 sans-serif; }
#meshcat-pane, #live-pane { position: absolute; left: 0; top: 0; width: 100vw; height: 100vh; overflow: hidden;
  border: 0; }
#vd-panel { position: absolute; left: 8px; top: 8px; max-width: 360px; max-height: 90vh; overflow-y: auto;
  background: rgba(255,255,255,0.88); border-radius: 6px; padding: 8px 10px; z-index: 10; }
#vd-panel h1 { font-size: 14px; margin: 0 0 4px; }
.vd-row { padding: 3px 6px; cursor: pointer; border-radius: 4px; white-space: nowrap; }
.vd-row:hover { background: #dde8f5; }
.vd-row.vd-on { background: #1f77b4; color: white; }
.vd-unstable { color: #c00; font-weight: bold; }
.vd-row.vd-on.vd-unstable { color: #ffd; }
#vd-status { margin-top: 6px; color: #333; }
#vd-controls { margin-top: 6px; }
"""

PANEL_JS = """
function vdParams() {
  const out = {};
  for (const part of location.hash.replace(/^#/, "").split("&")) {
    const [k, v] = part.split("=");
    if (k) out[decodeURIComponent(k)] = decodeURIComponent(v || "");
  }
  return out;
}
function vdMark(k) {
  document.querySelectorAll(".vd-row").forEach((r, i) => r.classList.toggle("vd-on", i === k));
  document.getElementById("vd-status").textContent = VD.motions[k].status;
  VD.current = k;
}
"""

OFFLINE_JS = """
function vdBytes(o) {
  if (Array.isArray(o)) return o.map(vdBytes);
  if (o && typeof o === "object") {
    if (typeof o.__b64 === "string") return Uint8Array.from(atob(o.__b64), c => c.charCodeAt(0));
    for (const k in o) o[k] = vdBytes(o[k]);
  }
  return o;
}
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
for (const cmd of vdBytes(JSON.parse(document.getElementById("vd-scene").textContent))) viewer.handle_command(cmd);
const VD_ANIMS = JSON.parse(document.getElementById("vd-animations").textContent);
function vdShow(k, t) {
  viewer.handle_command({type: "set_animation", animations: JSON.parse(JSON.stringify(VD_ANIMS[k])),
                         options: {play: true, repetitions: Infinity}});
  vdMark(k);
  if (t !== undefined && !isNaN(t)) { viewer.animator.seek(t); viewer.animator.pause(); }
  vdPlayLabel();
}
function vdToggle() {
  if (viewer.animator.playing) viewer.animator.pause(); else viewer.animator.play();
  vdPlayLabel();
}
function vdPlayLabel() {
  document.getElementById("vd-play").textContent = viewer.animator.playing ? "pause" : "play";
}
function vdTick() {
  const m = VD.motions[VD.current];
  if (m && m.clock) {
    document.getElementById("vd-time").textContent = "t = " + (viewer.animator.time * m.speed).toFixed(3) + " s";
  }
  requestAnimationFrame(vdTick);
}
function vdFromHash() {
  const p = vdParams();
  const k = Math.max(0, Math.min(VD.motions.length - 1, (parseInt(p.mode || String(VD.current + 1)) || 1) - 1));
  vdShow(k, p.t === undefined ? undefined : parseFloat(p.t));
}
window.addEventListener("hashchange", vdFromHash);
document.querySelectorAll(".vd-row").forEach((r, i) => r.addEventListener("click", () => vdShow(i)));
vdFromHash();
vdTick();
"""

LIVE_JS = """
function vdShow(k) {
  const a = document.getElementById("vd-amplitude");
  fetch("show?n=" + k + (a && a.value ? "&amplitude=" + encodeURIComponent(a.value) : ""))
    .then(r => r.json()).then(s => { vdMark(s.current); });
}
function vdToggle() {
  fetch("toggle").then(r => r.json()).then(s => {
    document.getElementById("vd-play").textContent = s.playing ? "pause" : "play"; });
}
document.querySelectorAll(".vd-row").forEach((r, i) => r.addEventListener("click", () => vdShow(i)));
setInterval(() => {
  if (!VD.motions[VD.current].clock) { document.getElementById("vd-time").textContent = ""; return; }
  fetch("state").then(r => r.json()).then(s => {
    if (s.t !== undefined) document.getElementById("vd-time").textContent = "t = " + s.t.toFixed(2) + " s"; });
}, 250);
const vdP = vdParams();
if (vdP.mode !== undefined) vdShow(Math.max(0, (parseInt(vdP.mode) || 1) - 1)); else vdMark(VD.current);
"""


def _panel(title, subtitle, motions, live):
    rows = "\n".join(
        f'<div class="vd-row{" vd-unstable" if m.get("unstable") else ""}" data-index="{i}">'
        f'{html.escape(m["label"])}</div>' for i, m in enumerate(motions))
    amp = ('<label> amplitude (m) <input id="vd-amplitude" type="number" min="0" step="any" size="7" '
           'placeholder="auto"></label>') if live else ""
    return f"""<div id="vd-panel">
<h1>{html.escape(title)}</h1><div>{html.escape(subtitle)}</div>
<div id="vd-list">{rows}</div>
<div id="vd-controls"><button id="vd-play" onclick="vdToggle()">pause</button> {amp}
<span id="vd-time"></span></div>
<div id="vd-status"></div>
</div>"""


def offline_page(title, subtitle, motions, scene_cmds, animations, current=0):
    """The self-contained page: meshcat's viewer inlined, the scene, and one animation per motion (``current``, 0-based,
    shown first unless the address's #mode= says otherwise)."""
    js = (meshcat_dist() / "main.min.js").read_text(encoding="utf-8")
    meta = {"motions": motions, "current": current}
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(title)}</title><style>{PANEL_CSS}</style></head>
<body>
<div id="meshcat-pane"></div>
{_panel(title, subtitle, motions, False)}
<script>{js}</script>
<script type="application/json" id="vd-scene">{to_json(scene_cmds)}</script>
<script type="application/json" id="vd-animations">{to_json(animations)}</script>
<script>const VD = {to_json(meta)};{PANEL_JS}{OFFLINE_JS}</script>
</body></html>
"""


def live_page(title, subtitle, motions, meshcat_url, current):
    """The live page: meshcat's own page (served by its server) in a frame, the panel driving the server."""
    meta = {"motions": motions, "current": current}
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(title)}</title><style>{PANEL_CSS}</style></head>
<body>
<iframe id="live-pane" src="{html.escape(meshcat_url)}"></iframe>
{_panel(title, subtitle, motions, True)}
<script>const VD = {to_json(meta)};{PANEL_JS}{LIVE_JS}</script>
</body></html>
"""
