// ObjectSplat scene viewer: the composed scene's .glb in WebGL2, with picking, rigid
// edits, duplicate / remove / recolor, undo, and the edits as the RON list that the
// `edit_scene` node accepts. No dependencies and no network: the page carries the .glb
// (base64) and the scene description (JSON) in two data blocks (script elements) next to
// this code.
//
// The scene is shown in the capture's frame (Z up); the .glb root node's Z-up → Y-up
// rotation is for other tools and is not applied here. Each member is drawn from the
// mesh of its .glb node (vertices relative to the member's pivot) under the member's
// placement, kept in full precision from the JSON: the placement arithmetic below
// repeats objectsplat-scene's `placement.rs` operation for operation, so an edit done
// here and the same edit replayed by `edit_scene` give the same doubles.
(function () {
  "use strict";

  const root = document.currentScript.closest(".osv");

  // ---- placement arithmetic (mirrors nodes/scene/src/placement.rs) ----

  function quatFromAxisAngle(axis, degrees) {
    const length = Math.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    const half = degrees * (Math.PI / 180) * 0.5;
    const s = Math.sin(half) / length;
    return [axis[0] * s, axis[1] * s, axis[2] * s, Math.cos(half)];
  }

  function quatMul(a, b) {
    const [ax, ay, az, aw] = a;
    const [bx, by, bz, bw] = b;
    return [
      aw * bx + ax * bw + ay * bz - az * by,
      aw * by - ax * bz + ay * bw + az * bx,
      aw * bz + ax * by - ay * bx + az * bw,
      aw * bw - ax * bx - ay * by - az * bz,
    ];
  }

  function quatNormalized(q) {
    const length = Math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (length === 0 || !Number.isFinite(length)) return [0, 0, 0, 1];
    return q.map((v) => v / length);
  }

  function quatToMatrix(q) {
    const [x, y, z, w] = quatNormalized(q);
    return [
      [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ];
  }

  function moved(p, by) {
    return {
      ...p,
      translation: [p.translation[0] + by[0], p.translation[1] + by[1], p.translation[2] + by[2]],
    };
  }

  function rotated(p, axis, degrees) {
    return { ...p, rotation: quatMul(quatFromAxisAngle(axis, degrees), p.rotation) };
  }

  function scaled(p, factor) {
    return { ...p, scale: p.scale * factor };
  }

  /** A point of the member's node frame (relative to its pivot) in the world. */
  function nodeToWorld(p, q) {
    const r = quatToMatrix(p.rotation);
    const out = p.translation.slice();
    for (let i = 0; i < 3; i++) {
      out[i] += p.scale * (r[i][0] * q[0] + r[i][1] * q[1] + r[i][2] * q[2]);
    }
    return out;
  }

  // ---- small vector / matrix helpers (column-major 4×4 for WebGL) ----

  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [
    a[1] * b[2] - a[2] * b[1],
    a[2] * b[0] - a[0] * b[2],
    a[0] * b[1] - a[1] * b[0],
  ];
  const norm = (a) => Math.sqrt(dot(a, a));
  const unit = (a) => mul(a, 1 / (norm(a) || 1));

  function mat4Mul(a, b) {
    const out = new Float64Array(16);
    for (let c = 0; c < 4; c++) {
      for (let r = 0; r < 4; r++) {
        let s = 0;
        for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
        out[c * 4 + r] = s;
      }
    }
    return out;
  }

  function perspective(fovY, aspect, near, far) {
    const f = 1 / Math.tan(fovY / 2);
    const out = new Float64Array(16);
    out[0] = f / aspect;
    out[5] = f;
    out[10] = (far + near) / (near - far);
    out[11] = -1;
    out[14] = (2 * far * near) / (near - far);
    return out;
  }

  function lookAt(eye, target, up) {
    const z = unit(sub(eye, target));
    const x = unit(cross(up, z));
    const y = cross(z, x);
    return new Float64Array([
      x[0], y[0], z[0], 0,
      x[1], y[1], z[1], 0,
      x[2], y[2], z[2], 0,
      -dot(x, eye), -dot(y, eye), -dot(z, eye), 1,
    ]);
  }

  /** The member's node transform (translation · rotation · scale) as a 4×4 matrix. */
  function placementMatrix(p) {
    const r = quatToMatrix(p.rotation);
    const s = p.scale;
    const t = p.translation;
    return new Float64Array([
      r[0][0] * s, r[1][0] * s, r[2][0] * s, 0,
      r[0][1] * s, r[1][1] * s, r[2][1] * s, 0,
      r[0][2] * s, r[1][2] * s, r[2][2] * s, 0,
      t[0], t[1], t[2], 1,
    ]);
  }

  // ---- data: the scene description and the .glb ----

  function base64Bytes(text) {
    const binary = atob(text.replace(/\s+/g, ""));
    const bytes = new Uint8Array(binary.length);
    for (let i = 0; i < binary.length; i++) bytes[i] = binary.charCodeAt(i);
    return bytes;
  }

  /** The meshes of a .glb written by objectsplat-export, by node name. */
  function parseGlb(bytes) {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    if (bytes.byteLength < 12 || view.getUint32(0, true) !== 0x46546c67) {
      throw new Error("the embedded scene is not a .glb (bad magic)");
    }
    if (view.getUint32(4, true) !== 2) throw new Error("the embedded .glb is not glTF 2.0");
    let json = null;
    let bin = null;
    for (let offset = 12; offset + 8 <= bytes.byteLength; ) {
      const length = view.getUint32(offset, true);
      const type = view.getUint32(offset + 4, true);
      const chunk = bytes.subarray(offset + 8, offset + 8 + length);
      if (type === 0x4e4f534a) json = JSON.parse(new TextDecoder().decode(chunk));
      else if (type === 0x004e4942) bin = chunk;
      offset += 8 + length;
    }
    if (!json) throw new Error("the embedded .glb has no JSON chunk");
    const accessor = (index, type, componentType) => {
      const a = json.accessors[index];
      if (a.type !== type || a.componentType !== componentType || a.sparse) {
        throw new Error(`accessor ${index}: expected ${type}/${componentType}, found ${a.type}/${a.componentType}`);
      }
      const v = json.bufferViews[a.bufferView];
      if (v.byteStride && v.byteStride !== (type === "VEC3" ? 12 : 4)) {
        throw new Error(`accessor ${index}: interleaved data is not supported`);
      }
      const count = a.count * (type === "VEC3" ? 3 : 1);
      const start = (v.byteOffset || 0) + (a.byteOffset || 0);
      // Copied so the typed array starts aligned.
      const copy = bin.slice(start, start + count * 4);
      const data = componentType === 5126 ? new Float32Array(copy.buffer) : new Uint32Array(copy.buffer);
      return { data, min: a.min, max: a.max };
    };
    const meshes = new Map();
    for (const node of json.nodes || []) {
      if (node.mesh === undefined || !node.name) continue;
      const primitive = json.meshes[node.mesh].primitives[0];
      const positions = accessor(primitive.attributes.POSITION, "VEC3", 5126);
      const count = positions.data.length / 3;
      // View-dependent colour: `_SH_k` attributes, packed 16 coefficients × RGB per vertex.
      let shDegree = 0;
      while (shDegree < 3 && primitive.attributes[`_SH_${(shDegree + 2) * (shDegree + 2) - 1}`] !== undefined) shDegree++;
      let sh = null;
      if (shDegree > 0) {
        sh = new Float32Array(count * 48);
        for (let k = 0; k < (shDegree + 1) * (shDegree + 1); k++) {
          const values = accessor(primitive.attributes[`_SH_${k}`], "VEC3", 5126).data;
          for (let v = 0; v < count; v++) {
            for (let c = 0; c < 3; c++) sh[v * 48 + k * 3 + c] = values[v * 3 + c];
          }
        }
      }
      meshes.set(node.name, {
        positions: positions.data,
        colors: accessor(primitive.attributes.COLOR_0, "VEC3", 5126).data,
        indices: accessor(primitive.indices, "SCALAR", 5125).data,
        sh,
        shDegree,
        min: positions.min,
        max: positions.max,
      });
    }
    return meshes;
  }

  // ---- edits: validation, application (mirrors edit_scene), RON text ----

  /** `obj_<id>_<label>` with the label reduced to [a-z0-9_] (objectsplat-core's rule). */
  function objectItemName(id, label) {
    let clean = "";
    for (const c of label) clean += /^[A-Za-z0-9]$/.test(c) ? c.toLowerCase() : "_";
    return `obj_${id}_${clean}`;
  }

  const finite3 = (v) => Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === "number" && Number.isFinite(x));

  /** A plain-object edit checked and copied: `{op, target, …}` as `edit_scene` takes it. */
  function checkedEdit(edit) {
    if (!edit || typeof edit !== "object") throw new Error("an edit is an object such as {op: \"move\", target: NAME, by: [dx, dy, dz]}");
    const op = String(edit.op || "").toLowerCase();
    const target = edit.target;
    if (typeof target !== "string" || !target) throw new Error(`edit ${JSON.stringify(edit)}: target must be a member name`);
    const need3 = (field) => {
      if (!finite3(edit[field])) throw new Error(`${op} ${target}: ${field} must be three finite numbers`);
      return edit[field].slice();
    };
    switch (op) {
      case "move":
        return { op, target, by: need3("by") };
      case "rotate": {
        const axis = need3("axis");
        if (norm(axis) <= 1e-12) throw new Error(`rotate ${target}: axis has zero length`);
        if (typeof edit.degrees !== "number" || !Number.isFinite(edit.degrees)) throw new Error(`rotate ${target}: degrees must be a finite number`);
        return { op, target, axis, degrees: edit.degrees };
      }
      case "scale":
        if (typeof edit.factor !== "number" || !(edit.factor > 0) || !Number.isFinite(edit.factor)) {
          throw new Error(`scale ${target}: factor must be finite and positive`);
        }
        return { op, target, factor: edit.factor };
      case "duplicate":
        return { op, target, offset: need3("offset") };
      case "remove":
        return { op, target };
      case "recolor": {
        const rgb = need3("rgb");
        if (!rgb.every((c) => c >= 0 && c <= 1)) throw new Error(`recolor ${target}: rgb must lie in [0, 1]`);
        return { op, target, rgb };
      }
      default:
        throw new Error(`unknown edit op ${JSON.stringify(edit.op)}; ops: move, rotate, scale, duplicate, remove, recolor`);
    }
  }

  /** Applies one checked edit to `members` in place; returns the new member's name for a duplicate. */
  function applyEdit(members, e) {
    const index = members.findIndex((m) => m.name === e.target);
    if (index < 0) {
      throw new Error(`no scene member is named ${JSON.stringify(e.target)}; the scene has: ${members.map((m) => m.name).join(", ")}`);
    }
    const m = members[index];
    switch (e.op) {
      case "move":
        m.placement = moved(m.placement, e.by);
        return null;
      case "rotate":
        m.placement = rotated(m.placement, e.axis, e.degrees);
        return null;
      case "scale":
        m.placement = scaled(m.placement, e.factor);
        return null;
      case "duplicate": {
        if (m.kind !== "object") throw new Error(`${JSON.stringify(m.name)} is the background; only objects can be duplicated`);
        const id = Math.max(0, ...members.map((o) => o.id || 0)) + 1;
        if (id > 65534) throw new Error(`no free object id is left for a copy of ${JSON.stringify(m.name)}`);
        const label = m.label || "";
        const copy = { ...m, id, label, name: objectItemName(id, label), placement: moved(m.placement, e.offset) };
        members.push(copy);
        return copy.name;
      }
      case "remove":
        members.splice(index, 1);
        return null;
      case "recolor":
        m.color = e.rgb.slice();
        return null;
    }
    return null;
  }

  /** A number as RON reads it back to the same double. */
  function ronNumber(x) {
    if (Object.is(x, -0)) return "-0.0";
    return String(x).replace("e+", "e");
  }

  const ron3 = (v) => `(${v.map(ronNumber).join(", ")})`;

  function ronEdit(e) {
    const target = `Name(${JSON.stringify(e.target)})`;
    switch (e.op) {
      case "move":
        return `Move(target: ${target}, by: ${ron3(e.by)})`;
      case "rotate":
        return `Rotate(target: ${target}, axis: ${ron3(e.axis)}, degrees: ${ronNumber(e.degrees)})`;
      case "scale":
        return `Scale(target: ${target}, factor: ${ronNumber(e.factor)})`;
      case "duplicate":
        return `Duplicate(target: ${target}, offset: ${ron3(e.offset)})`;
      case "remove":
        return `Remove(target: ${target})`;
      case "recolor":
        return `Recolor(target: ${target}, rgb: ${ron3(e.rgb)})`;
    }
    return "";
  }

  // ---- page set-up ----

  function element(tag, className, text) {
    const e = document.createElement(tag);
    if (className) e.className = className;
    if (text !== undefined) e.textContent = text;
    return e;
  }

  function showFailure(message) {
    const box = element("div", "osv-failure", `The 3D view cannot start: ${message}`);
    root.appendChild(box);
  }

  let resolveReady;
  let rejectReady;
  const ready = new Promise((resolve, reject) => {
    resolveReady = resolve;
    rejectReady = reject;
  });

  const data = JSON.parse(root.querySelector(".osv-data").textContent);
  const view = element("div", "osv-view");
  const canvas = element("canvas", "osv-canvas");
  canvas.tabIndex = 0;
  const tag = element("div", "osv-tag");
  tag.hidden = true;
  const help = element(
    "div",
    "osv-help",
    "drag: orbit · right-drag / shift-drag: pan · wheel: zoom · click: select · on the selection: drag moves, shift-drag lifts, ctrl-drag turns, alt-drag scales · keys: arrows / PgUp / PgDn move, Q / E turn, + / − scale, D duplicate, Del remove, Ctrl+Z undo, F frame, Esc deselect",
  );
  view.append(canvas, tag);
  const panel = element("aside", "osv-panel");
  const heading = element("h2", "osv-title", data.title || "Scene");
  const selectedBox = element("div", "osv-selected", "Nothing selected");
  const tools = element("div", "osv-tools");
  const button = (text, title, action) => {
    const b = element("button", "osv-button", text);
    b.type = "button";
    b.title = title;
    b.addEventListener("click", action);
    tools.appendChild(b);
    return b;
  };
  const list = element("ul", "osv-list");
  const status = element("p", "osv-status");
  panel.append(heading, selectedBox, tools, list, status, help);
  const dialog = element("div", "osv-dialog");
  dialog.hidden = true;
  const dialogBox = element("div", "osv-dialog-box");
  const dialogText = element("textarea", "osv-edits");
  dialogText.readOnly = true;
  dialogText.spellcheck = false;
  const dialogNote = element(
    "p",
    "osv-note",
    "The edits that made this scene, then yours, in the form edit_scene's `edits` parameter takes: objectsplat run GRAPH --set NODE.edits='…' (NODE: the edit_scene node fed by the composed scene) reproduces what you see.",
  );
  const dialogButtons = element("div", "osv-tools");
  dialogBox.append(element("h3", "", "Edits"), dialogNote, dialogText, dialogButtons);
  dialog.appendChild(dialogBox);
  root.prepend(view, panel);
  root.appendChild(dialog);

  const gl = canvas.getContext("webgl2", { antialias: false, preserveDrawingBuffer: false });
  if (!gl) {
    showFailure("this browser has no WebGL2");
    rejectReady(new Error("no WebGL2"));
    window.objectsplat = { ready };
    return;
  }

  let meshes;
  try {
    meshes = parseGlb(base64Bytes(root.querySelector(".osv-glb").textContent));
  } catch (err) {
    showFailure(err.message);
    rejectReady(err);
    window.objectsplat = { ready };
    return;
  }

  // The scene as loaded: members with their placements (full precision) and meshes.
  const initial = data.members.map((m) => ({
    name: m.name,
    kind: m.kind,
    id: m.id === null || m.id === undefined ? null : m.id,
    label: m.label === undefined ? null : m.label,
    mesh: m.name,
    placement: m.placement,
    color: null,
  }));
  const earlierEdits = (data.edits || []).slice();
  /** Edits done here, checked, in order; `members` is `initial` with them applied. */
  const done = [];
  let members = [];
  /** A drag in progress: an edit shown but not yet done. */
  let pending = null;
  let selected = null;

  function rebuild() {
    const next = initial.map((m) => ({ ...m }));
    for (const e of done) applyEdit(next, e);
    if (pending) applyEdit(next, pending);
    members = next;
    if (selected && !members.some((m) => m.name === selected)) selected = null;
  }

  // ---- GPU resources ----

  function compile(vertex, fragment) {
    const program = gl.createProgram();
    for (const [type, source] of [
      [gl.VERTEX_SHADER, vertex],
      [gl.FRAGMENT_SHADER, fragment],
    ]) {
      const shader = gl.createShader(type);
      gl.shaderSource(shader, source);
      gl.compileShader(shader);
      if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(shader));
      gl.attachShader(program, shader);
    }
    gl.bindAttribLocation(program, 0, "a_position");
    gl.bindAttribLocation(program, 1, "a_color");
    SH_SLOTS.forEach((name, i) => gl.bindAttribLocation(program, 2 + i, name));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
    const uniforms = {};
    for (let i = 0; i < gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS); i++) {
      const name = gl.getActiveUniform(program, i).name;
      uniforms[name] = gl.getUniformLocation(program, name);
    }
    return { program, uniforms };
  }

  // The SH coefficients arrive as 12 vec4 attributes (16 coefficients × RGB).
  const SH_SLOTS = Array.from({ length: 12 }, (_, i) => `a_sh${i}`);
  const SH_FLOATS = SH_SLOTS.flatMap((a) => ["x", "y", "z", "w"].map((c) => `${a}.${c}`)).join(", ");
  // As the renderer colours a vertex (objectsplat-raster's sh.rs, the 3DGS basis): along
  // the direction from the eye to the vertex in the member's own frame, so a turned
  // member keeps the appearance it was trained with.
  const VERTEX = `#version 300 es
  precision highp float;
  uniform mat4 u_view_proj;
  uniform mat4 u_model;
  uniform int u_sh_degree;
  uniform vec3 u_eye_local;
  in vec3 a_position;
  in vec3 a_color;
  ${SH_SLOTS.map((a) => `in vec4 ${a};`).join("\n  ")}
  out vec3 v_color;
  vec3 k(float c[48], int i) { return vec3(c[3 * i], c[3 * i + 1], c[3 * i + 2]); }
  void main() {
    v_color = a_color;
    if (u_sh_degree > 0) {
      float c[48] = float[48](${SH_FLOATS});
      vec3 d = a_position - u_eye_local;
      d = length(d) > 0.0 ? normalize(d) : vec3(0.0);
      float x = d.x, y = d.y, z = d.z;
      vec3 rgb = 0.5 + 0.28209479177387814 * k(c, 0)
        - 0.4886025119029199 * y * k(c, 1) + 0.4886025119029199 * z * k(c, 2) - 0.4886025119029199 * x * k(c, 3);
      if (u_sh_degree > 1) {
        float xx = x * x, yy = y * y, zz = z * z;
        rgb += 1.0925484305920792 * x * y * k(c, 4) - 1.0925484305920792 * y * z * k(c, 5)
          + 0.31539156525252005 * (2.0 * zz - xx - yy) * k(c, 6) - 1.0925484305920792 * x * z * k(c, 7)
          + 0.5462742152960396 * (xx - yy) * k(c, 8);
        if (u_sh_degree > 2) {
          rgb += -0.5900435899266435 * y * (3.0 * xx - yy) * k(c, 9) + 2.890611442640554 * x * y * z * k(c, 10)
            - 0.4570457994644658 * y * (4.0 * zz - xx - yy) * k(c, 11)
            + 0.3731763325901154 * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * k(c, 12)
            - 0.4570457994644658 * x * (4.0 * zz - xx - yy) * k(c, 13) + 1.445305721320277 * z * (xx - yy) * k(c, 14)
            - 0.5900435899266435 * x * (xx - 3.0 * yy) * k(c, 15);
        }
      }
      v_color = max(rgb, 0.0);
    }
    gl_Position = u_view_proj * u_model * vec4(a_position, 1.0);
  }`;
  // Vertex colours are linear (glTF); the canvas shows sRGB-encoded values. Colours from
  // SH are sRGB already, as the renderer's. A recolored member shows its sRGB colour as
  // given; the selection is tinted.
  const SHADED = compile(
    VERTEX,
    `#version 300 es
  precision highp float;
  in vec3 v_color;
  uniform bool u_recolored;
  uniform bool u_sh;
  uniform vec3 u_color;
  uniform float u_tint;
  out vec4 o_color;
  vec3 encode(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
  }
  void main() {
    vec3 c = u_recolored ? u_color : u_sh ? clamp(v_color, 0.0, 1.0) : encode(v_color);
    o_color = vec4(mix(c, vec3(1.0, 0.55, 0.0), u_tint), 1.0);
  }`,
  );
  // One flat colour per member: its index + 1 in 24 bits (picking), or the outline colour.
  const FLAT = compile(
    VERTEX,
    `#version 300 es
  precision highp float;
  uniform vec3 u_color;
  out vec4 o_color;
  void main() { o_color = vec4(u_color, 1.0); }`,
  );

  const gpuMeshes = new Map();
  for (const [name, mesh] of meshes) {
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    for (const [location, values] of [
      [0, mesh.positions],
      [1, mesh.colors],
    ]) {
      const buffer = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.bufferData(gl.ARRAY_BUFFER, values, gl.STATIC_DRAW);
      gl.enableVertexAttribArray(location);
      gl.vertexAttribPointer(location, 3, gl.FLOAT, false, 0, 0);
    }
    if (mesh.sh) {
      const buffer = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.bufferData(gl.ARRAY_BUFFER, mesh.sh, gl.STATIC_DRAW);
      for (let i = 0; i < 12; i++) {
        gl.enableVertexAttribArray(2 + i);
        gl.vertexAttribPointer(2 + i, 4, gl.FLOAT, false, 48 * 4, i * 16);
      }
    }
    const indices = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, indices);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, mesh.indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    gpuMeshes.set(name, { vao, count: mesh.indices.length, shDegree: mesh.shDegree });
  }
  // The selection outline: the 12 edges of the mesh's local bounding box.
  const outline = (() => {
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const buffer = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
    gl.bindVertexArray(null);
    return { vao, buffer };
  })();

  // ---- bounds and camera ----

  function localCorners(mesh) {
    const corners = [];
    for (let k = 0; k < 8; k++) {
      corners.push([k & 1 ? mesh.max[0] : mesh.min[0], k & 2 ? mesh.max[1] : mesh.min[1], k & 4 ? mesh.max[2] : mesh.min[2]]);
    }
    return corners;
  }

  function worldBounds(which) {
    let lo = [Infinity, Infinity, Infinity];
    let hi = [-Infinity, -Infinity, -Infinity];
    for (const m of which) {
      const mesh = meshes.get(m.mesh);
      if (!mesh) continue;
      for (const c of localCorners(mesh)) {
        const p = nodeToWorld(m.placement, c);
        lo = lo.map((v, k) => Math.min(v, p[k]));
        hi = hi.map((v, k) => Math.max(v, p[k]));
      }
    }
    return Number.isFinite(lo[0]) ? { lo, hi } : null;
  }

  const camera = { target: [0, 0, 0], distance: 1, yaw: 0, pitch: 0, fovY: (50 * Math.PI) / 180 };
  let sceneRadius = 1;

  function eye() {
    const c = Math.cos(camera.pitch);
    return add(camera.target, mul([c * Math.cos(camera.yaw), c * Math.sin(camera.yaw), Math.sin(camera.pitch)], camera.distance));
  }

  function resetCamera() {
    const all = worldBounds(members) || { lo: [-1, -1, -1], hi: [1, 1, 1] };
    sceneRadius = Math.max(norm(sub(all.hi, all.lo)) / 2, 1e-3);
    const objects = worldBounds(members.filter((m) => m.kind === "object")) || all;
    const focus = mul(add(objects.lo, objects.hi), 0.5);
    const start = data.camera;
    if (start) {
      camera.fovY = (start.fov_y_degrees * Math.PI) / 180;
      camera.target = start.target.slice();
      const offset = sub(start.eye, start.target);
      camera.distance = Math.max(norm(offset), 1e-3);
      camera.yaw = Math.atan2(offset[1], offset[0]);
      camera.pitch = Math.asin(Math.max(-1, Math.min(1, offset[2] / camera.distance)));
    } else {
      const radius = Math.max(norm(sub(objects.hi, objects.lo)) / 2, 1e-3);
      camera.target = focus;
      camera.distance = (radius / Math.sin(camera.fovY / 2)) * 1.1;
      camera.yaw = (-60 * Math.PI) / 180;
      camera.pitch = (30 * Math.PI) / 180;
    }
  }

  function matrices() {
    const width = canvas.width;
    const height = canvas.height;
    const e = eye();
    const near = Math.max(camera.distance * 0.002, sceneRadius * 1e-5);
    const far = camera.distance + sceneRadius * 4;
    const view = lookAt(e, camera.target, [0, 0, 1]);
    const proj = perspective(camera.fovY, width / Math.max(height, 1), near, far);
    return { eye: e, view, viewProj: mat4Mul(proj, view) };
  }

  /** The world ray through CSS pixel (x, y) of the canvas. */
  function ray(x, y) {
    const e = eye();
    const forward = unit(sub(camera.target, e));
    const right = unit(cross(forward, [0, 0, 1]));
    const up = cross(right, forward);
    const h = Math.tan(camera.fovY / 2);
    const aspect = canvas.clientWidth / Math.max(canvas.clientHeight, 1);
    const nx = ((2 * x) / canvas.clientWidth - 1) * h * aspect;
    const ny = (1 - (2 * y) / canvas.clientHeight) * h;
    return { origin: e, direction: unit(add(forward, add(mul(right, nx), mul(up, ny)))) };
  }

  /** Where CSS pixel (x, y) projects from a world point, or null behind the camera. */
  function project(viewProj, p) {
    const x = viewProj[0] * p[0] + viewProj[4] * p[1] + viewProj[8] * p[2] + viewProj[12];
    const y = viewProj[1] * p[0] + viewProj[5] * p[1] + viewProj[9] * p[2] + viewProj[13];
    const w = viewProj[3] * p[0] + viewProj[7] * p[1] + viewProj[11] * p[2] + viewProj[15];
    if (w <= 0) return null;
    return [((x / w + 1) / 2) * canvas.clientWidth, ((1 - y / w) / 2) * canvas.clientHeight];
  }

  // ---- drawing and picking ----

  const BACKDROP = [0.16, 0.17, 0.19];
  let idTarget = null;
  let idFresh = false;

  function fitCanvas() {
    const ratio = window.devicePixelRatio || 1;
    const width = Math.max(1, Math.round(canvas.clientWidth * ratio));
    const height = Math.max(1, Math.round(canvas.clientHeight * ratio));
    if (canvas.width !== width || canvas.height !== height) {
      canvas.width = width;
      canvas.height = height;
    }
  }

  /** Whether background members are drawn (and pickable): hiding the room helps to see into it. */
  let showBackground = true;

  /** The eye in the member's own frame: the inverse of its placement applied to the eye. */
  function eyeInMember(p, e) {
    const r = quatToMatrix(p.rotation);
    const d = sub(e, p.translation);
    return [0, 1, 2].map((i) => (r[0][i] * d[0] + r[1][i] * d[1] + r[2][i] * d[2]) / p.scale);
  }

  function drawMembers(program, perMember) {
    const { viewProj, eye: e } = matrices();
    gl.useProgram(program.program);
    gl.uniformMatrix4fv(program.uniforms.u_view_proj, false, new Float32Array(viewProj));
    members.forEach((m, index) => {
      const mesh = gpuMeshes.get(m.mesh);
      if (!mesh || (!showBackground && m.kind === "background")) return;
      gl.uniformMatrix4fv(program.uniforms.u_model, false, new Float32Array(placementMatrix(m.placement)));
      // Flat-colour passes (picking, outline) need no view-dependent colour.
      const shDegree = program === SHADED ? mesh.shDegree : 0;
      // A uniform the compiler dropped from a program has no location (null: a no-op).
      gl.uniform1i(program.uniforms.u_sh_degree ?? null, shDegree);
      gl.uniform1i(program.uniforms.u_sh ?? null, shDegree > 0 ? 1 : 0);
      if (shDegree > 0) gl.uniform3fv(program.uniforms.u_eye_local ?? null, eyeInMember(m.placement, e));
      perMember(m, index);
      gl.bindVertexArray(mesh.vao);
      gl.drawElements(gl.TRIANGLES, mesh.count, gl.UNSIGNED_INT, 0);
    });
    gl.bindVertexArray(null);
    return viewProj;
  }

  function draw() {
    fitCanvas();
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, canvas.width, canvas.height);
    gl.enable(gl.DEPTH_TEST);
    gl.disable(gl.CULL_FACE);
    gl.clearColor(BACKDROP[0], BACKDROP[1], BACKDROP[2], 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    const viewProj = drawMembers(SHADED, (m) => {
      gl.uniform1i(SHADED.uniforms.u_recolored, m.color ? 1 : 0);
      gl.uniform3fv(SHADED.uniforms.u_color, m.color || [0, 0, 0]);
      gl.uniform1f(SHADED.uniforms.u_tint, m.name === selected ? 0.35 : 0);
    });
    const chosen = members.find((m) => m.name === selected);
    tag.hidden = true;
    if (chosen) {
      const mesh = meshes.get(chosen.mesh);
      if (mesh) {
        const c = localCorners(mesh);
        const edges = [0, 1, 1, 3, 3, 2, 2, 0, 4, 5, 5, 7, 7, 6, 6, 4, 0, 4, 1, 5, 2, 6, 3, 7];
        gl.bindBuffer(gl.ARRAY_BUFFER, outline.buffer);
        gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(edges.flatMap((k) => c[k])), gl.DYNAMIC_DRAW);
        gl.useProgram(FLAT.program);
        gl.uniformMatrix4fv(FLAT.uniforms.u_view_proj, false, new Float32Array(viewProj));
        gl.uniformMatrix4fv(FLAT.uniforms.u_model, false, new Float32Array(placementMatrix(chosen.placement)));
        gl.uniform3fv(FLAT.uniforms.u_color, [1.0, 0.55, 0.0]);
        gl.disable(gl.DEPTH_TEST);
        gl.bindVertexArray(outline.vao);
        gl.drawArrays(gl.LINES, 0, edges.length);
        gl.bindVertexArray(null);
        gl.enable(gl.DEPTH_TEST);
      }
      const at = project(viewProj, chosen.placement.translation);
      if (at && at[0] >= 0 && at[1] >= 0 && at[0] <= canvas.clientWidth && at[1] <= canvas.clientHeight) {
        tag.textContent = chosen.label ? `${chosen.label} · ${chosen.name}` : chosen.name;
        tag.style.left = `${at[0]}px`;
        tag.style.top = `${at[1]}px`;
        tag.hidden = false;
      }
    }
    idFresh = false;
  }

  let frameRequested = false;
  function requestDraw() {
    // Picking before the frame is drawn must see the new camera too.
    idFresh = false;
    if (frameRequested) return;
    frameRequested = true;
    requestAnimationFrame(() => {
      frameRequested = false;
      draw();
    });
  }

  /** Renders member index + 1 into an off-screen target of the canvas's size. */
  function renderIds() {
    fitCanvas();
    const { width, height } = canvas;
    if (!idTarget || idTarget.width !== width || idTarget.height !== height) {
      if (idTarget) {
        gl.deleteFramebuffer(idTarget.framebuffer);
        gl.deleteRenderbuffer(idTarget.color);
        gl.deleteRenderbuffer(idTarget.depth);
      }
      const framebuffer = gl.createFramebuffer();
      const color = gl.createRenderbuffer();
      const depth = gl.createRenderbuffer();
      gl.bindRenderbuffer(gl.RENDERBUFFER, color);
      gl.renderbufferStorage(gl.RENDERBUFFER, gl.RGBA8, width, height);
      gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
      gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, width, height);
      gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.RENDERBUFFER, color);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
      idTarget = { framebuffer, color, depth, width, height };
    }
    gl.bindFramebuffer(gl.FRAMEBUFFER, idTarget.framebuffer);
    gl.viewport(0, 0, width, height);
    gl.enable(gl.DEPTH_TEST);
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    drawMembers(FLAT, (m, index) => {
      const k = index + 1;
      gl.uniform3fv(FLAT.uniforms.u_color, [(k & 255) / 255, ((k >> 8) & 255) / 255, ((k >> 16) & 255) / 255]);
    });
    idFresh = true;
  }

  /** The member drawn at CSS pixel (x, y) of the canvas, or null. */
  function pick(x, y) {
    if (typeof x !== "number" || typeof y !== "number" || !Number.isFinite(x) || !Number.isFinite(y)) {
      throw new Error("pick(x, y) takes two finite numbers (CSS pixels of the canvas)");
    }
    fitCanvas();
    const px = Math.floor((x * canvas.width) / canvas.clientWidth);
    const py = Math.floor((y * canvas.height) / canvas.clientHeight);
    if (px < 0 || py < 0 || px >= canvas.width || py >= canvas.height) return null;
    if (!idFresh) renderIds();
    gl.bindFramebuffer(gl.FRAMEBUFFER, idTarget.framebuffer);
    const pixel = new Uint8Array(4);
    gl.readPixels(px, canvas.height - 1 - py, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    const k = pixel[0] | (pixel[1] << 8) | (pixel[2] << 16);
    return k > 0 && k <= members.length ? members[k - 1].name : null;
  }

  // ---- the panel ----

  function describe(m) {
    const p = m.placement.translation.map((v) => v.toFixed(3)).join(", ");
    return `${m.label ? m.label : m.kind}${m.id ? ` (id ${m.id})` : ""} — ${m.name}\nat (${p}), scale ${+m.placement.scale.toFixed(4)}`;
  }

  function refreshPanel() {
    list.replaceChildren(
      ...members.map((m) => {
        const item = element("li", m.name === selected ? "osv-item osv-chosen" : "osv-item");
        item.append(element("span", "osv-name", m.label || m.kind), element("span", "osv-member", m.name));
        item.addEventListener("click", () => {
          select(m.name);
          // So the keys act on it right away.
          canvas.focus();
        });
        return item;
      }),
    );
    const chosen = members.find((m) => m.name === selected);
    selectedBox.textContent = chosen ? describe(chosen) : "Nothing selected: click an object";
    if (chosen && chosen.color) {
      colorInput.value = "#" + chosen.color.map((c) => Math.round(c * 255).toString(16).padStart(2, "0")).join("");
    }
    for (const b of [duplicateButton, removeButton, colorInput]) b.disabled = !chosen;
    duplicateButton.disabled = !chosen || chosen.kind !== "object";
    undoButton.disabled = done.length === 0;
    status.textContent = `${members.length} members · ${done.length} edit${done.length === 1 ? "" : "s"} here${earlierEdits.length ? ` · ${earlierEdits.length} earlier` : ""}`;
  }

  function select(name) {
    selected = name;
    refreshPanel();
    draw();
  }

  function report(err) {
    status.textContent = err.message;
    status.classList.add("osv-error");
    setTimeout(() => status.classList.remove("osv-error"), 3000);
  }

  /** Does `edit` (checked) and redraws; throws, leaving everything as it was, when it fails. */
  function perform(edit) {
    const e = checkedEdit(edit);
    const trial = initial.map((m) => ({ ...m }));
    for (const d of done) applyEdit(trial, d);
    const created = applyEdit(trial, e);
    done.push(e);
    pending = null;
    rebuild();
    refreshPanel();
    draw();
    return created;
  }

  function undo() {
    if (!done.length) return;
    done.pop();
    rebuild();
    refreshPanel();
    draw();
  }

  function editsText() {
    const items = earlierEdits.concat(done.map(ronEdit));
    return items.length ? `[\n${items.map((t) => `    ${t},\n`).join("")}]` : "[]";
  }

  /** A step of about 2% of the scene's size, rounded to 1, 2 or 5 × 10^k. */
  function niceStep(size) {
    const power = Math.pow(10, Math.floor(Math.log10(size)));
    const m = size / power;
    return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * power;
  }

  const round = (v, step) => {
    const r = Math.round(v / step) * step;
    // Trims binary noise (0.30000000000000004) from the RON text.
    return +r.toPrecision(12);
  };

  /** The camera's horizontal forward and right, snapped to the world's ±X / ±Y. */
  function groundAxes() {
    const f = sub(camera.target, eye());
    const forward = Math.abs(f[0]) >= Math.abs(f[1]) ? [Math.sign(f[0]) || 1, 0, 0] : [0, Math.sign(f[1]) || 1, 0];
    return { forward, right: cross(forward, [0, 0, 1]) };
  }

  function duplicateSelected() {
    const chosen = members.find((m) => m.name === selected);
    if (!chosen || chosen.kind !== "object") return;
    const b = worldBounds([chosen]);
    const { right } = groundAxes();
    const width = b ? Math.abs(dot(sub(b.hi, b.lo), right)) : sceneRadius * 0.1;
    const step = niceStep(sceneRadius * 0.02);
    const offset = right.map((v) => round(v * Math.max(width * 1.2, step), step * 0.1));
    try {
      select(perform({ op: "duplicate", target: chosen.name, offset }));
    } catch (err) {
      report(err);
    }
  }

  function removeSelected() {
    if (!selected) return;
    try {
      perform({ op: "remove", target: selected });
    } catch (err) {
      report(err);
    }
  }

  const duplicateButton = button("Duplicate", "copy the selected object next to it (D)", duplicateSelected);
  const removeButton = button("Remove", "remove the selected member (Delete)", removeSelected);
  const colorInput = element("input", "osv-color");
  colorInput.type = "color";
  colorInput.title = "recolor the selected member";
  colorInput.addEventListener("change", () => {
    if (!selected) return;
    const hex = colorInput.value;
    const rgb = [1, 3, 5].map((i) => round(parseInt(hex.slice(i, i + 2), 16) / 255, 1e-4));
    try {
      perform({ op: "recolor", target: selected, rgb });
    } catch (err) {
      report(err);
    }
  });
  tools.appendChild(colorInput);
  const undoButton = button("Undo", "undo the last edit (Ctrl+Z)", undo);
  button("Export edits", "the edits as edit_scene's RON list", () => {
    dialogText.value = editsText();
    dialog.hidden = false;
    dialogText.focus();
    dialogText.select();
  });
  button("Reset view", "back to the starting camera", () => {
    resetCamera();
    requestDraw();
  });
  const backgroundToggle = element("label", "osv-toggle");
  const backgroundBox = element("input");
  backgroundBox.type = "checkbox";
  backgroundBox.checked = true;
  backgroundBox.addEventListener("change", () => {
    showBackground = backgroundBox.checked;
    draw();
  });
  backgroundToggle.append(backgroundBox, " background");
  backgroundToggle.title = "show the background (uncheck to see into a room)";
  tools.appendChild(backgroundToggle);
  const copyButton = element("button", "osv-button", "Copy");
  copyButton.type = "button";
  copyButton.addEventListener("click", () => {
    dialogText.select();
    if (navigator.clipboard && window.isSecureContext) {
      navigator.clipboard.writeText(dialogText.value).catch((err) => report(err));
    } else {
      // file:// pages are not a secure context; the selection can still be copied.
      document.execCommand("copy");
    }
  });
  const closeButton = element("button", "osv-button", "Close");
  closeButton.type = "button";
  closeButton.addEventListener("click", () => {
    dialog.hidden = true;
  });
  dialogButtons.append(copyButton, closeButton);

  // ---- mouse and keys ----

  let gesture = null;

  function ground(x, y, height) {
    const r = ray(x, y);
    if (Math.abs(r.direction[2]) < 1e-9) return null;
    const t = (height - r.origin[2]) / r.direction[2];
    return t > 0 ? add(r.origin, mul(r.direction, t)) : null;
  }

  function vertical(x, y, through) {
    const r = ray(x, y);
    const away = sub(r.origin, through);
    const normal = unit([away[0], away[1], 0]);
    const denom = dot(r.direction, normal);
    if (Math.abs(denom) < 1e-9) return null;
    const t = dot(sub(through, r.origin), normal) / denom;
    return t > 0 ? add(r.origin, mul(r.direction, t)) : null;
  }

  function localPoint(event) {
    const rect = canvas.getBoundingClientRect();
    return [event.clientX - rect.left, event.clientY - rect.top];
  }

  /** The edit an object drag from the gesture's start to (x, y) stands for, or null. */
  function dragEdit(x, y) {
    const g = gesture;
    const limit = sceneRadius * 20;
    const step = niceStep(sceneRadius * 0.02) * 0.01;
    if (g.kind === "turn") {
      const degrees = Math.round((x - g.start[0]) * 0.5);
      return degrees ? { op: "rotate", target: g.name, axis: [0, 0, 1], degrees } : null;
    }
    if (g.kind === "grow") {
      const factor = round(Math.pow(2, -(y - g.start[1]) / 150), 1e-3);
      return factor > 0 && factor !== 1 ? { op: "scale", target: g.name, factor } : null;
    }
    if (g.kind === "lift") {
      const hit = vertical(x, y, g.anchor);
      if (!hit) return null;
      const dz = round(Math.max(-limit, Math.min(limit, hit[2] - g.anchor[2])), step);
      return dz ? { op: "move", target: g.name, by: [0, 0, dz] } : null;
    }
    const hit = ground(x, y, g.anchor[2]);
    if (!hit) return null;
    const by = [0, 1].map((k) => round(Math.max(-limit, Math.min(limit, hit[k] - g.anchor[k])), step));
    return by[0] || by[1] ? { op: "move", target: g.name, by: [by[0], by[1], 0] } : null;
  }

  canvas.addEventListener("contextmenu", (event) => event.preventDefault());
  canvas.addEventListener("pointerdown", (event) => {
    canvas.focus();
    const [x, y] = localPoint(event);
    const under = event.button === 0 ? pick(x, y) : null;
    let kind;
    if (under && under === selected) {
      kind = event.ctrlKey || event.metaKey ? "turn" : event.altKey ? "grow" : event.shiftKey ? "lift" : "slide";
    } else {
      kind = event.button === 0 && !event.shiftKey ? "orbit" : "pan";
    }
    const chosen = members.find((m) => m.name === selected);
    let anchor = null;
    if (kind === "slide" || kind === "lift") {
      const r = ray(x, y);
      // The grab point on the plane through the object's pivot height.
      anchor = ground(x, y, chosen.placement.translation[2]) || chosen.placement.translation.slice();
      if (kind === "lift") anchor = vertical(x, y, chosen.placement.translation) || add(r.origin, r.direction);
    }
    gesture = { kind, start: [x, y], last: [x, y], moved: false, under, name: selected, anchor, pointer: event.pointerId };
    canvas.setPointerCapture(event.pointerId);
    event.preventDefault();
  });
  canvas.addEventListener("pointermove", (event) => {
    if (!gesture || event.pointerId !== gesture.pointer) return;
    const [x, y] = localPoint(event);
    if (!gesture.moved && Math.hypot(x - gesture.start[0], y - gesture.start[1]) < 3) return;
    gesture.moved = true;
    const [dx, dy] = [x - gesture.last[0], y - gesture.last[1]];
    gesture.last = [x, y];
    if (gesture.kind === "orbit") {
      camera.yaw -= dx * 0.008;
      camera.pitch = Math.max(-1.55, Math.min(1.55, camera.pitch + dy * 0.008));
    } else if (gesture.kind === "pan") {
      const e = eye();
      const forward = unit(sub(camera.target, e));
      const right = unit(cross(forward, [0, 0, 1]));
      const up = cross(right, forward);
      const perPixel = (2 * camera.distance * Math.tan(camera.fovY / 2)) / Math.max(canvas.clientHeight, 1);
      camera.target = add(camera.target, add(mul(right, -dx * perPixel), mul(up, dy * perPixel)));
    } else {
      pending = dragEdit(x, y);
      rebuild();
      refreshPanel();
    }
    requestDraw();
  });
  const endGesture = (event) => {
    if (!gesture || event.pointerId !== gesture.pointer) return;
    const g = gesture;
    gesture = null;
    if (!g.moved) {
      pending = null;
      rebuild();
      select(g.under);
      return;
    }
    if (pending) {
      const edit = pending;
      pending = null;
      try {
        perform(edit);
      } catch (err) {
        rebuild();
        report(err);
      }
    }
    requestDraw();
  };
  canvas.addEventListener("pointerup", endGesture);
  canvas.addEventListener("pointercancel", endGesture);
  canvas.addEventListener(
    "wheel",
    (event) => {
      event.preventDefault();
      camera.distance = Math.max(sceneRadius * 1e-3, camera.distance * Math.pow(1.0015, event.deltaY));
      requestDraw();
    },
    { passive: false },
  );

  root.addEventListener("keydown", (event) => {
    if (event.target === dialogText || event.target instanceof HTMLInputElement) return;
    const key = event.key;
    if (key === "Escape") {
      dialog.hidden = true;
      select(null);
      return;
    }
    if ((event.ctrlKey || event.metaKey) && key.toLowerCase() === "z") {
      undo();
      event.preventDefault();
      return;
    }
    if (key === "Home") {
      resetCamera();
      requestDraw();
      return;
    }
    const chosen = members.find((m) => m.name === selected);
    if (!chosen || event.ctrlKey || event.metaKey || event.altKey) return;
    const step = niceStep(sceneRadius * 0.02) * (event.shiftKey ? 0.2 : 1);
    const { forward, right } = groundAxes();
    const moves = {
      ArrowUp: forward,
      ArrowDown: mul(forward, -1),
      ArrowRight: right,
      ArrowLeft: mul(right, -1),
      PageUp: [0, 0, 1],
      PageDown: [0, 0, -1],
    };
    let edit = null;
    if (moves[key]) edit = { op: "move", target: chosen.name, by: moves[key].map((v) => round(v * step, step * 0.01) + 0) };
    else if (key === "q" || key === "Q") edit = { op: "rotate", target: chosen.name, axis: [0, 0, 1], degrees: 15 };
    else if (key === "e" || key === "E") edit = { op: "rotate", target: chosen.name, axis: [0, 0, 1], degrees: -15 };
    else if (key === "+" || key === "=") edit = { op: "scale", target: chosen.name, factor: 1.25 };
    else if (key === "-" || key === "_") edit = { op: "scale", target: chosen.name, factor: 0.8 };
    else if (key === "d" || key === "D") {
      duplicateSelected();
      event.preventDefault();
      return;
    } else if (key === "Delete" || key === "Backspace") {
      removeSelected();
      event.preventDefault();
      return;
    } else if (key === "f" || key === "F") {
      camera.target = chosen.placement.translation.slice();
      requestDraw();
      return;
    }
    if (!edit) return;
    event.preventDefault();
    try {
      perform(edit);
    } catch (err) {
      report(err);
    }
  });

  if (typeof ResizeObserver === "function") new ResizeObserver(() => requestDraw()).observe(canvas);

  // ---- start ----

  rebuild();
  resetCamera();
  refreshPanel();
  draw();

  window.objectsplat = {
    /** Resolves (to true) once the scene is drawn; rejects when the view cannot start. */
    ready,
    /** The scene's members now: `[{name, label}]` (label null for the background). */
    objects: () => members.map((m) => ({ name: m.name, label: m.label })),
    /** The member drawn at CSS pixel (x, y) of the canvas, or null. */
    pick,
    /** Does an edit given as a plain object (`{op: "move", target: NAME, by: [dx, dy, dz]}`,
     *  `rotate` {axis, degrees}, `scale` {factor}, `duplicate` {offset}, `remove`,
     *  `recolor` {rgb}); returns the copy's name for a duplicate, else null. */
    apply: (edit) => perform(edit),
    /** Every edit (the scene's earlier ones, then those done here) as edit_scene's RON list. */
    edits: editsText,
    /** A member's node transform now ({translation, rotation [x, y, z, w], scale}, the
     *  .glb node's convention, full precision), or null. */
    transform: (name) => {
      const m = members.find((o) => o.name === name);
      if (!m) return null;
      const p = m.placement;
      return { translation: p.translation.slice(), rotation: quatNormalized(p.rotation), scale: p.scale };
    },
    /** Undoes the last edit done here. */
    undo,
  };
  // The first frame was drawn above, synchronously.
  resolveReady(true);
})();
