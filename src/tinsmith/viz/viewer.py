"""An interactive 3-D view of a mesh: a pyvista window where there is a screen, else one offline HTML page.

The page is self-contained: the mesh travels inside it as base64 arrays and
a small WebGL program written here draws it (no library, no request to
anywhere).  Drag to turn, wheel to zoom, ``w`` toggles the wireframe; the
page sets ``data-ready`` on its body once the first frame is drawn.
"""

from __future__ import annotations

import base64
import html
import json
import os
from pathlib import Path

import numpy as np

from ..core import TerrainMesh
from ..errors import InvalidInputError
from ..io import atomic_paths

__all__ = ["show", "viewer_html", "write_viewer"]

_TERRAIN = np.array([  # (height share, r, g, b): a terrain ramp from lowland green to snow
    (0.00, 51, 102, 153), (0.05, 0, 153, 102), (0.35, 204, 204, 119), (0.65, 153, 119, 85), (1.00, 255, 255, 255),
])


def _colours(z: np.ndarray) -> np.ndarray:
    lo, hi = float(z.min()), float(z.max())
    t = (z - lo) / (hi - lo) if hi > lo else np.zeros_like(z)
    return np.column_stack([np.interp(t, _TERRAIN[:, 0], _TERRAIN[:, k]) for k in (1, 2, 3)]).astype(np.uint8)


def _normals(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    face = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    acc = np.zeros_like(v)
    for k in range(3):
        np.add.at(acc, t[:, k], face)
    n = np.linalg.norm(acc, axis=1, keepdims=True)
    return np.where(n > 0, acc / np.where(n > 0, n, 1), [0.0, 0.0, 1.0])


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def viewer_html(mesh: TerrainMesh, *, title: str = "mesh", exaggeration: float = 1.0) -> str:
    """The viewer page of ``mesh`` (heights times ``exaggeration``)."""
    if mesh.n_triangles == 0:
        raise InvalidInputError("the mesh has no triangles to show")
    v = mesh.vertices.astype(np.float64)
    t = mesh.triangles.astype(np.int64)
    centre = (v.min(axis=0) + v.max(axis=0)) / 2
    span = float(max(np.ptp(v[:, 0]), np.ptp(v[:, 1]), 1e-12))
    p = (v - centre) / span * 2.0  # the x-y extent fits in [-1, 1]
    p[:, 2] *= exaggeration
    edges = np.unique(np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1), axis=0)
    data = {
        "positions": _b64(p.astype(np.float32)), "normals": _b64(_normals(p, t).astype(np.float32)),
        "colours": _b64(_colours(v[:, 2])), "triangles": _b64(t.astype(np.uint32)), "edges": _b64(edges.astype(np.uint32)),
        "n_vertices": len(v), "n_triangles": len(t), "n_edges": len(edges),
    }
    caption = (f"{html.escape(title)}: {mesh.n_vertices:,} vertices, {mesh.n_triangles:,} triangles; "
               "drag to turn, wheel to zoom, w for the wireframe")
    return _PAGE.replace("@TITLE@", html.escape(title)).replace("@CAPTION@", caption).replace(
        "@DATA@", json.dumps(data))


def write_viewer(mesh: TerrainMesh, path, **kwargs) -> Path:
    """Write :func:`viewer_html` to ``path`` atomically."""
    path = Path(path)
    with atomic_paths(path) as (tmp,):
        tmp.write_text(viewer_html(mesh, **kwargs), encoding="utf-8")
    return path


def show(mesh: TerrainMesh, *, title: str = "mesh", exaggeration: float = 1.0) -> bool:
    """Open a pyvista window when there is a screen and pyvista is installed; False when there is not."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False
    try:
        import pyvista
    except ImportError:
        return False
    v = mesh.vertices.copy()
    v[:, 2] *= exaggeration
    faces = np.hstack([np.full((mesh.n_triangles, 1), 3), mesh.triangles]).ravel()
    plotter = pyvista.Plotter(title=title)
    plotter.add_mesh(pyvista.PolyData(v, faces), scalars=mesh.vertices[:, 2], cmap="terrain", show_edges=False)
    plotter.show()
    return True


_PAGE = r"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>@TITLE@</title>
<style>html,body{margin:0;height:100%;background:#1d2229;color:#ddd;font-family:system-ui,sans-serif;overflow:hidden}
#c{width:100%;height:100%;display:block}#cap{position:absolute;left:.8rem;top:.6rem;font-size:.85rem}</style>
</head><body><canvas id="c"></canvas><div id="cap">@CAPTION@</div>
<script type="application/json" id="mesh">@DATA@</script>
<script>
"use strict";
(function () {
  const data = JSON.parse(document.getElementById("mesh").textContent);
  const bytes = (s) => { const b = atob(s); const u = new Uint8Array(b.length);
    for (let i = 0; i < b.length; i++) u[i] = b.charCodeAt(i); return u.buffer; };
  const pos = new Float32Array(bytes(data.positions)), nor = new Float32Array(bytes(data.normals));
  const col = new Uint8Array(bytes(data.colours)), tri = new Uint32Array(bytes(data.triangles));
  const edg = new Uint32Array(bytes(data.edges));
  const canvas = document.getElementById("c");
  const gl = canvas.getContext("webgl2", { antialias: true });
  if (!gl) { document.getElementById("cap").textContent = "This browser has no WebGL 2: the mesh cannot be drawn here.";
    document.body.dataset.ready = "no-webgl"; return; }
  function shader(type, src) { const s = gl.createShader(type); gl.shaderSource(s, src); gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s)); return s; }
  function program(vs, fs) { const p = gl.createProgram();
    gl.attachShader(p, shader(gl.VERTEX_SHADER, vs)); gl.attachShader(p, shader(gl.FRAGMENT_SHADER, fs));
    gl.linkProgram(p); if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p)); return p; }
  const surf = program(`#version 300 es
    in vec3 p; in vec3 n; in vec3 c; uniform mat4 m; out vec3 vc; out vec3 vn;
    void main() { gl_Position = m * vec4(p, 1.0); vc = c; vn = n; }`,
    `#version 300 es
    precision mediump float; in vec3 vc; in vec3 vn; out vec4 o;
    void main() { vec3 l = normalize(vec3(-0.5, 0.6, 0.75)); float d = max(dot(normalize(vn), l), 0.0);
      o = vec4(vc * (0.35 + 0.65 * d), 1.0); }`);
  const wire = program(`#version 300 es
    in vec3 p; uniform mat4 m; void main() { gl_Position = m * vec4(p, 1.0); gl_Position.z -= 0.0005 * gl_Position.w; }`,
    `#version 300 es
    precision mediump float; out vec4 o; void main() { o = vec4(0.05, 0.05, 0.05, 1.0); }`);
  function buffer(target, array) { const b = gl.createBuffer(); gl.bindBuffer(target, b);
    gl.bufferData(target, array, gl.STATIC_DRAW); return b; }
  const bp = buffer(gl.ARRAY_BUFFER, pos), bn = buffer(gl.ARRAY_BUFFER, nor), bc = buffer(gl.ARRAY_BUFFER, col);
  const bt = buffer(gl.ELEMENT_ARRAY_BUFFER, tri), be = buffer(gl.ELEMENT_ARRAY_BUFFER, edg);
  function attribute(prog, name, buf, size, type, normalized) { const at = gl.getAttribLocation(prog, name); if (at < 0) return;
    gl.bindBuffer(gl.ARRAY_BUFFER, buf); gl.enableVertexAttribArray(at);
    gl.vertexAttribPointer(at, size, type, normalized, 0, 0); }
  const vaoS = gl.createVertexArray(); gl.bindVertexArray(vaoS);
  attribute(surf, "p", bp, 3, gl.FLOAT, false); attribute(surf, "n", bn, 3, gl.FLOAT, false);
  attribute(surf, "c", bc, 3, gl.UNSIGNED_BYTE, true);
  gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, bt);
  const vaoW = gl.createVertexArray(); gl.bindVertexArray(vaoW);
  attribute(wire, "p", bp, 3, gl.FLOAT, false); gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, be);
  gl.bindVertexArray(null);
  let az = -0.6, el = 0.75, dist = 2.6, wireframe = data.n_triangles < 20000;
  function matrix() {
    const w = canvas.width, h = canvas.height, f = 1 / Math.tan(0.4), near = 0.01, far = 50;
    const P = [f * h / w, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) / (near - far), -1, 0, 0, 2 * far * near / (near - far), 0];
    const ex = dist * Math.cos(el) * Math.sin(az), ey = -dist * Math.cos(el) * Math.cos(az), ez = dist * Math.sin(el);
    let zx = ex, zy = ey, zz = ez; let l = Math.hypot(zx, zy, zz); zx /= l; zy /= l; zz /= l;
    let xx = -zy, xy = zx, xz = 0; l = Math.hypot(xx, xy) || 1; xx /= l; xy /= l;
    const yx = zy * xz - zz * xy, yy = zz * xx - zx * xz, yz = zx * xy - zy * xx;
    const V = [xx, yx, zx, 0, xy, yy, zy, 0, xz, yz, zz, 0,
               -(xx * ex + xy * ey + xz * ez), -(yx * ex + yy * ey + yz * ez), -(zx * ex + zy * ey + zz * ez), 1];
    const M = new Float32Array(16);
    for (let i = 0; i < 4; i++) for (let j = 0; j < 4; j++) {
      let s = 0; for (let k = 0; k < 4; k++) s += P[k * 4 + j] * V[i * 4 + k]; M[i * 4 + j] = s; }
    return M;
  }
  function draw() {
    const dpr = window.devicePixelRatio || 1, w = Math.round(canvas.clientWidth * dpr), h = Math.round(canvas.clientHeight * dpr);
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    gl.viewport(0, 0, canvas.width, canvas.height); gl.clearColor(0.11, 0.13, 0.16, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST); const M = matrix();
    gl.useProgram(surf); gl.uniformMatrix4fv(gl.getUniformLocation(surf, "m"), false, M);
    gl.bindVertexArray(vaoS); gl.drawElements(gl.TRIANGLES, tri.length, gl.UNSIGNED_INT, 0);
    if (wireframe) { gl.useProgram(wire); gl.uniformMatrix4fv(gl.getUniformLocation(wire, "m"), false, M);
      gl.bindVertexArray(vaoW); gl.drawElements(gl.LINES, edg.length, gl.UNSIGNED_INT, 0); }
    gl.bindVertexArray(null);
    document.body.dataset.ready = "1";
  }
  let drag = null;
  canvas.addEventListener("pointerdown", (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
  canvas.addEventListener("pointerup", () => { drag = null; });
  canvas.addEventListener("pointermove", (e) => { if (!drag) return; az -= (e.clientX - drag[0]) * 0.008;
    el = Math.min(1.55, Math.max(0.05, el + (e.clientY - drag[1]) * 0.008)); drag = [e.clientX, e.clientY];
    requestAnimationFrame(draw); });
  canvas.addEventListener("wheel", (e) => { e.preventDefault();
    dist = Math.min(20, Math.max(0.3, dist * Math.exp(e.deltaY * 0.001))); requestAnimationFrame(draw); }, { passive: false });
  window.addEventListener("keydown", (e) => { if (e.key === "w") { wireframe = !wireframe; requestAnimationFrame(draw); } });
  window.addEventListener("resize", () => requestAnimationFrame(draw));
  draw();
})();
</script></body></html>
"""
