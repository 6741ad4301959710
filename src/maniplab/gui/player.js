// maniplab's offline replay player: plain WebGL, no library, nothing fetched.
// The page holds #ml-meta (JSON: runs, parts, camera, floor; see maniplab.gui.player) and
// #ml-data (base64 of the zlib-compressed arrays the meta's "blob" index places).
"use strict";
(async function () {
  const meta = JSON.parse(document.getElementById("ml-meta").textContent);
  const POSE = 8; // floats per part per frame: position (3), quaternion w x y z, length scale
  const GROWTH = 1.01; // ghosts drawn this much larger: where one nearly coincides with the solid
  // arm (the base, a joint that did not move), equal depths would otherwise speckle

  async function inflate() {
    const text = atob(document.getElementById("ml-data").textContent.trim());
    const packed = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) packed[i] = text.charCodeAt(i);
    const stream = new Blob([packed]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Response(stream).arrayBuffer();
  }

  const buffer = await inflate();
  function array(name) {
    const [kind, offset, count] = meta.blob[name];
    const Type = { f4: Float32Array, u4: Uint32Array, u1: Uint8Array }[kind];
    return new Type(buffer, offset, count);
  }

  // --- small vector and matrix helpers (column-major 4x4) -------------------------------------
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                           a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => Math.hypot(a[0], a[1], a[2]);
  const unit = (a) => scale(a, 1 / (norm(a) || 1));

  function multiply(a, b) {
    const out = new Float32Array(16);
    for (let c = 0; c < 4; c++)
      for (let r = 0; r < 4; r++)
        out[c * 4 + r] = a[r] * b[c * 4] + a[4 + r] * b[c * 4 + 1] + a[8 + r] * b[c * 4 + 2] +
                         a[12 + r] * b[c * 4 + 3];
    return out;
  }
  function perspective(fovy, aspect, near, far) {
    const f = 1 / Math.tan(fovy / 2), out = new Float32Array(16);
    out[0] = f / aspect; out[5] = f; out[10] = (far + near) / (near - far); out[11] = -1;
    out[14] = 2 * far * near / (near - far);
    return out;
  }
  function lookAt(eye, target, up) {
    const z = unit(sub(eye, target)), x = unit(cross(up, z)), y = cross(z, x);
    return new Float32Array([x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0,
                             -dot(x, eye), -dot(y, eye), -dot(z, eye), 1]);
  }
  function rotate(v, axis, angle) { // Rodrigues: v turned by angle (rad) about the unit axis
    const c = Math.cos(angle), s = Math.sin(angle), k = axis;
    return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
  }
  // model matrix and normal matrix (rotation times inverse scale) of a part's pose
  const model = new Float32Array(16), normalMat = new Float32Array(9);
  function place(pose, o, radius, grow = 1) {
    const px = pose[o], py = pose[o + 1], pz = pose[o + 2];
    const w = pose[o + 3], x = pose[o + 4], y = pose[o + 5], z = pose[o + 6];
    const sz = pose[o + 7] * grow, sx = radius * grow;
    const r = [1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y),
               2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x),
               2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)];
    const s = [sx, sx, sz];
    for (let c = 0; c < 3; c++) {
      for (let i = 0; i < 3; i++) {
        model[c * 4 + i] = r[c * 3 + i] * s[c];
        normalMat[c * 3 + i] = r[c * 3 + i] / s[c];
      }
      model[c * 4 + 3] = 0;
    }
    model[12] = px; model[13] = py; model[14] = pz; model[15] = 1;
  }

  // --- WebGL ----------------------------------------------------------------------------------
  const canvas = document.getElementById("ml-view");
  const gl = canvas.getContext("webgl", { antialias: !softwareGL(), alpha: false });
  if (!gl) throw new Error("this browser has no WebGL");
  // A GPU reset (a driver's, or a software rasteriser's process stopped by its watchdog on a
  // loaded machine) takes the context away: ask for it back, and start the page again with it
  // (every buffer is made at the start; the page holds all its data).
  canvas.addEventListener("webglcontextlost", (e) => e.preventDefault());
  canvas.addEventListener("webglcontextrestored", () => location.reload());
  if (!gl.getExtension("OES_element_index_uint")) throw new Error("WebGL lacks 32-bit indices");

  function softwareGL() { // a CPU rasteriser (SwiftShader, llvmpipe): no multisampling, it
    // would cost about a third of the frame rate; a GPU smooths the edges for free
    const probe = document.createElement("canvas").getContext("webgl");
    const info = probe && probe.getExtension("WEBGL_debug_renderer_info");
    const name = info ? String(probe.getParameter(info.UNMASKED_RENDERER_WEBGL)) : "";
    if (probe) probe.getExtension("WEBGL_lose_context")?.loseContext();
    return /swiftshader|llvmpipe|software/i.test(name);
  }
  function program(vertex, fragment) {
    const p = gl.createProgram();
    for (const [type, source] of [[gl.VERTEX_SHADER, vertex], [gl.FRAGMENT_SHADER, fragment]]) {
      const s = gl.createShader(type);
      gl.shaderSource(s, source);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      gl.attachShader(p, s);
    }
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
    const names = {};
    const count = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS);
    for (let i = 0; i < count; i++) {
      const name = gl.getActiveUniform(p, i).name;
      names[name] = gl.getUniformLocation(p, name);
    }
    return { p, u: names, pos: gl.getAttribLocation(p, "aPos"),
             normal: gl.getAttribLocation(p, "aNormal") };
  }
  // lit per vertex (ambient 0.45 and a directional light 0.55, never above 1: a colour keeps
  // its r:g:b): a CPU rasteriser spends its time per pixel, and flat faces have split vertices
  const meshProgram = program(`
    attribute vec3 aPos; attribute vec3 aNormal;
    uniform mat4 uViewProj; uniform mat4 uModel; uniform mat3 uNormal;
    uniform vec3 uLight; uniform float uLit;
    varying float vLight;
    void main() {
      vLight = uLit > 0.5 ? 0.45 + 0.55 * max(dot(normalize(uNormal * aNormal), uLight), 0.0)
                          : 1.0;
      gl_Position = uViewProj * uModel * vec4(aPos, 1.0);
    }`, `
    precision mediump float;
    uniform vec4 uColour;
    varying float vLight;
    void main() { gl_FragColor = vec4(uColour.rgb * vLight, uColour.a); }`);
  const lineProgram = program(`
    attribute vec3 aPos; uniform mat4 uViewProj;
    void main() { gl_Position = uViewProj * vec4(aPos, 1.0); }`, `
    precision mediump float; uniform vec4 uColour;
    void main() { gl_FragColor = uColour; }`);

  function vbo(data, target = gl.ARRAY_BUFFER) {
    const b = gl.createBuffer();
    gl.bindBuffer(target, b);
    gl.bufferData(target, data, gl.STATIC_DRAW);
    return b;
  }
  const meshes = meta.meshes.map((name) => {
    const index = array(name + ".i");
    return { pos: vbo(array(name + ".p")), normal: vbo(array(name + ".n")),
             index: vbo(index, gl.ELEMENT_ARRAY_BUFFER), count: index.length };
  });
  const colours = meta.colours;
  const runs = meta.runs.map((run) => ({
    ...run, poses: array(run.arrays.poses), colourIndex: array(run.arrays.colours),
    path: array(run.arrays.path), lineData: array(run.arrays.lines),
    pathBuffer: vbo(array(run.arrays.path)), lineBuffer: gl.createBuffer() }));

  function floorLines() { // the grid in the floor plane (minor and section lines), the axes
    const { up_axis: up, size, cell, section, axes } = meta.floor;
    const [a, b] = [0, 1, 2].filter((i) => i !== up), half = size / 2;
    const minor = [], major = [];
    const n = Math.round(size / cell);
    for (let i = 0; i <= n; i++) {
      const v = -half + i * cell;
      const onSection = Math.abs(v / section - Math.round(v / section)) < 1e-6;
      for (const [u, w] of [[a, b], [b, a]]) {
        const p = [0, 0, 0], q = [0, 0, 0];
        p[u] = v; p[w] = -half; q[u] = v; q[w] = half;
        (onSection ? major : minor).push(...p, ...q);
      }
    }
    const h = Math.SQRT1_2; // the axes: the unit cylinder (along z) turned onto x, y and z
    const turns = [[h, 0, h, 0], [h, -h, 0, 0], [1, 0, 0, 0]];
    return { minor: { buffer: vbo(new Float32Array(minor)), count: minor.length / 3 },
             major: { buffer: vbo(new Float32Array(major)), count: major.length / 3 },
             axes: { parts: [0, 1, 2].map(() => ({ mesh: meta.floor.axes_mesh,
                                                   radius: meta.floor.axes_radius })),
                     poses: new Float32Array(turns.flatMap((q) => [0, 0, 0, ...q, axes])),
                     colours: [[0.9, 0.2, 0.2], [0.2, 0.75, 0.3], [0.2, 0.4, 1.0]] } };
  }
  const floor = floorLines();

  // --- camera: orbit about the target, zoom by distance ---------------------------------------
  const camera = { target: meta.camera.target.slice(), up: unit(meta.camera.up),
                   offset: sub(meta.camera.position, meta.camera.target),
                   fov: meta.camera.fov * Math.PI / 180 };
  let viewProj = new Float32Array(16), light = [0, 0, 1];
  function updateCamera() {
    const eye = add(camera.target, camera.offset), distance = norm(camera.offset);
    const aspect = canvas.width / Math.max(canvas.height, 1);
    const far = distance * 4 + meta.floor.size * 2;
    viewProj = multiply(perspective(camera.fov, aspect, Math.max(distance / 200, 1e-3), far),
                        lookAt(eye, camera.target, camera.up));
    const back = unit(camera.offset), right = unit(cross(camera.up, back));
    light = unit(add(add(back, scale(camera.up, 0.6)), scale(right, 0.35)));
  }
  function orbit(dx, dy) {
    camera.offset = rotate(camera.offset, camera.up, -dx * 0.008);
    const right = unit(cross(camera.up, camera.offset));
    const turned = rotate(camera.offset, right, -dy * 0.008);
    const angle = Math.acos(Math.max(-1, Math.min(1, dot(unit(turned), camera.up))));
    if (angle > 0.05 && angle < Math.PI - 0.05) camera.offset = turned;
  }
  function resize() {
    const ratio = window.devicePixelRatio || 1;
    canvas.width = Math.max(1, Math.round(canvas.clientWidth * ratio));
    canvas.height = Math.max(1, Math.round(canvas.clientHeight * ratio));
    pickTarget = null;
    dirty = true;
  }

  // --- drawing --------------------------------------------------------------------------------
  const state = { t: 0, speed: 1, playing: true, frame: 0, drawn: 0 };
  const duration = (meta.frames - 1) / meta.fps;
  let dirty = true, pickTarget = null;

  function drawParts(run, frame, alpha, pickBase) {
    const m = meshProgram, parts = run.parts, count = parts.length;
    for (let p = 0; p < count; p++) {
      const mesh = meshes[parts[p].mesh];
      place(run.poses, (frame * count + p) * POSE, parts[p].radius, run.ghost ? GROWTH : 1);
      if (pickBase === undefined) {
        const c = colours[run.colourIndex[frame * count + p]];
        gl.uniform4f(m.u.uColour, c[0], c[1], c[2], alpha);
      } else {
        const id = pickBase + p + 1;
        gl.uniform4f(m.u.uColour, (id & 255) / 255, ((id >> 8) & 255) / 255, 0, 1);
      }
      drawMesh(mesh);
    }
  }
  function drawMesh(mesh) { // at the model matrix and colour set
    const m = meshProgram;
    gl.uniformMatrix4fv(m.u.uModel, false, model);
    gl.uniformMatrix3fv(m.u.uNormal, false, normalMat);
    gl.bindBuffer(gl.ARRAY_BUFFER, mesh.pos);
    gl.vertexAttribPointer(m.pos, 3, gl.FLOAT, false, 0, 0);
    gl.bindBuffer(gl.ARRAY_BUFFER, mesh.normal);
    gl.vertexAttribPointer(m.normal, 3, gl.FLOAT, false, 0, 0);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, mesh.index);
    gl.drawElements(gl.TRIANGLES, mesh.count, gl.UNSIGNED_INT, 0);
  }
  function drawAxes() { // x red, y green, z blue, at the origin
    const m = meshProgram, mesh = meshes[meta.floor.axes_mesh], a = floor.axes;
    for (let i = 0; i < 3; i++) {
      place(a.poses, i * POSE, meta.floor.axes_radius);
      gl.uniform4f(m.u.uColour, ...a.colours[i], 1);
      drawMesh(mesh);
    }
  }
  function useMeshes(lit) {
    const m = meshProgram;
    gl.useProgram(m.p);
    gl.enableVertexAttribArray(m.pos);
    gl.enableVertexAttribArray(m.normal);
    gl.uniformMatrix4fv(m.u.uViewProj, false, viewProj);
    gl.uniform3fv(m.u.uLight, light);
    gl.uniform1f(m.u.uLit, lit ? 1 : 0);
  }
  function drawLines(buffer, count, colour, mode) {
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.vertexAttribPointer(lineProgram.pos, 3, gl.FLOAT, false, 0, 0);
    gl.uniform4fv(lineProgram.u.uColour, colour);
    gl.drawArrays(mode, 0, count);
  }
  function useLines() {
    gl.useProgram(lineProgram.p);
    gl.disableVertexAttribArray(meshProgram.normal);
    gl.enableVertexAttribArray(lineProgram.pos);
    gl.uniformMatrix4fv(lineProgram.u.uViewProj, false, viewProj);
  }
  function drawScene() {
    const frame = state.frame, bg = meta.background;
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, canvas.width, canvas.height);
    gl.clearColor(bg[0], bg[1], bg[2], 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LEQUAL);
    gl.depthMask(true);
    gl.disable(gl.BLEND);
    gl.enable(gl.CULL_FACE);
    useLines();
    drawLines(floor.minor.buffer, floor.minor.count, [0.27, 0.29, 0.33, 1], gl.LINES);
    drawLines(floor.major.buffer, floor.major.count, [0.42, 0.45, 0.50, 1], gl.LINES);
    useMeshes(true);
    drawAxes();
    runs.forEach((run) => { if (!run.ghost) drawParts(run, frame, 1); });
    useLines();
    gl.enable(gl.BLEND);
    gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA);
    for (const run of runs) {
      drawLines(run.pathBuffer, meta.frames, run.path_colour, gl.LINE_STRIP);
      if (run.lines > 0) {
        const n = run.lines * 6;
        gl.bindBuffer(gl.ARRAY_BUFFER, run.lineBuffer);
        gl.bufferData(gl.ARRAY_BUFFER, run.lineData.subarray(frame * n, frame * n + n), gl.DYNAMIC_DRAW);
        drawLines(run.lineBuffer, run.lines * 2, [...run.line_colour, run.ghost ? meta.ghost_alpha : 1],
                  gl.LINES);
      }
    }
    gl.depthMask(false); // ghosts after the solid arms, hiding nothing
    useMeshes(true);
    runs.forEach((run) => { if (run.ghost) drawParts(run, frame, meta.ghost_alpha); });
    gl.depthMask(true);
    state.drawn++;
  }

  // --- hover: an id pass drawn into one pixel of an offscreen buffer --------------------------
  function pickBuffer() {
    if (pickTarget) return pickTarget;
    const fb = gl.createFramebuffer(), colour = gl.createTexture();
    const depth = gl.createRenderbuffer();
    gl.bindTexture(gl.TEXTURE_2D, colour); // 8 bits a channel: the ids come back exact
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, canvas.width, canvas.height, 0, gl.RGBA,
                  gl.UNSIGNED_BYTE, null);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
    gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT16, canvas.width, canvas.height);
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, colour, 0);
    gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
    pickTarget = fb;
    return fb;
  }
  const owners = []; // id - 1 -> [run, part]
  runs.forEach((run, r) => run.parts.forEach((_, p) => owners.push([r, p])));
  function pick(x, y) { // CSS pixels from the canvas's top left -> [run, part] or null
    const ratio = canvas.width / Math.max(canvas.clientWidth, 1);
    const px = Math.floor(x * ratio), py = canvas.height - 1 - Math.floor(y * ratio);
    if (px < 0 || py < 0 || px >= canvas.width || py >= canvas.height) return null;
    gl.bindFramebuffer(gl.FRAMEBUFFER, pickBuffer());
    gl.viewport(0, 0, canvas.width, canvas.height);
    gl.enable(gl.SCISSOR_TEST);
    gl.scissor(px, py, 1, 1);
    gl.clearColor(0, 0, 0, 0);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LESS); // where a ghost coincides with the solid arm, the solid one is named
    gl.depthMask(true);
    gl.disable(gl.BLEND);
    useMeshes(false);
    let base = 0;
    for (const run of runs) { drawParts(run, state.frame, 1, base); base += run.parts.length; }
    const pixel = new Uint8Array(4);
    gl.readPixels(px, py, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
    gl.disable(gl.SCISSOR_TEST);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    dirty = true;
    const id = pixel[0] + 256 * pixel[1];
    return id > 0 && id <= owners.length ? owners[id - 1] : null;
  }

  // --- the page's controls ---------------------------------------------------------------------
  const play = document.getElementById("ml-play"), slider = document.getElementById("ml-slider");
  const readout = document.getElementById("ml-time"), speed = document.getElementById("ml-speed");
  const tip = document.getElementById("ml-tip");
  slider.max = String(meta.frames - 1);

  function frameOf(t) {
    return Math.min(Math.max(Math.floor(t * meta.fps + 1e-6), 0), meta.frames - 1);
  }
  const end = (meta.t0 + duration).toFixed(2);
  let shown = null;
  function show() { // the frame of the time reached; the controls touched only when it changes
    state.frame = frameOf(state.t);
    const now = `${state.frame} ${state.playing}`;
    if (now !== shown) {
      shown = now;
      slider.value = String(state.frame);
      readout.textContent = `${(meta.t0 + state.frame / meta.fps).toFixed(2)} s / ${end} s`;
      play.textContent = state.playing ? "Pause" : "Play";
    }
    dirty = true;
  }
  function seek(t) { state.t = Math.min(Math.max(t - meta.t0, 0), duration); show(); }
  function setPlaying(on) {
    if (on && state.t >= duration) state.t = 0;
    state.playing = on && meta.frames > 1;
    show();
  }
  play.addEventListener("click", () => setPlaying(!state.playing));
  slider.addEventListener("input", () => seek(meta.t0 + Number(slider.value) / meta.fps));
  speed.addEventListener("change", () => { state.speed = Number(speed.value); });
  const full = document.getElementById("ml-full");
  full.hidden = !document.fullscreenEnabled;  // e.g. inside a frame that does not allow it
  full.addEventListener("click", () => {
    if (document.fullscreenElement) document.exitFullscreen();
    else document.documentElement.requestFullscreen();
  });
  document.addEventListener("keydown", (e) => {
    if (e.key === " " && e.target.tagName !== "SELECT") {
      e.preventDefault();
      setPlaying(!state.playing);
    }
  });

  function buildKey() {
    const key = document.getElementById("ml-key");
    const row = (colour, text, ghost) => {
      const div = document.createElement("div"), swatch = document.createElement("span");
      div.className = "row";
      swatch.className = "swatch" + (ghost ? " ghost" : "");
      swatch.style.background = `rgb(${colour.map((c) => Math.round(c * 255)).join(",")})`;
      const label = document.createElement("span");
      label.textContent = text;
      div.append(swatch, label);
      key.append(div);
    };
    runs.forEach((run) => row(run.colour, `${run.label} (${run.ghost ? "ghost" : "solid"})`,
                               run.ghost));
    row(meta.states.stick, "joint held by stiction", false);
    row(meta.states.limit, "joint at a limit", false);
    const hint = document.createElement("div");
    hint.className = "hint";
    hint.textContent = "drag: orbit · wheel: zoom · space: play/pause · point at a part: its joint";
    key.append(hint);
  }
  buildKey();

  // pointer: drag orbits, hover names the joint under it
  let drag = null, hover = null, hoverFrame = -1;
  canvas.addEventListener("pointerdown", (e) => {
    drag = [e.clientX, e.clientY];
    canvas.setPointerCapture(e.pointerId);
    canvas.classList.add("dragging");
    tip.style.display = "none";
  });
  canvas.addEventListener("pointermove", (e) => {
    if (drag) {
      orbit(e.clientX - drag[0], e.clientY - drag[1]);
      drag = [e.clientX, e.clientY];
      updateCamera();
      dirty = true;
    } else {
      hover = [e.clientX, e.clientY];
      hoverFrame = -1;
    }
  });
  const release = () => { drag = null; canvas.classList.remove("dragging"); };
  canvas.addEventListener("pointerup", release);
  canvas.addEventListener("pointercancel", release);
  canvas.addEventListener("pointerleave", () => { hover = null; tip.style.display = "none"; });
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    camera.offset = scale(camera.offset, Math.exp(Math.max(-200, Math.min(200, e.deltaY)) * 0.0015));
    updateCamera();
    dirty = true;
  }, { passive: false });
  function nameAt(x, y) {
    const found = pick(x, y);
    if (!found) return null;
    const [r, p] = found;
    return runs.length > 1 ? `${runs[r].parts[p].name} · ${runs[r].label}` : runs[r].parts[p].name;
  }
  let picked = 0;
  function updateTip(now) { // at a pointer move, and while playing at most 5 times a second
    if (!hover || drag || hoverFrame === state.frame) return;
    if (hoverFrame !== -1 && now - picked < 200) return;
    hoverFrame = state.frame;
    picked = now;
    const rect = canvas.getBoundingClientRect();
    const name = nameAt(hover[0] - rect.left, hover[1] - rect.top);
    tip.style.display = name ? "block" : "none";
    if (name) {
      tip.textContent = name;
      tip.style.left = `${hover[0] + 14}px`;
      tip.style.top = `${hover[1] + 10}px`;
    }
  }

  // --- the loop -------------------------------------------------------------------------------
  let last = null;
  function loop(now) {
    const dt = last === null ? 0 : Math.min((now - last) / 1000, 0.25);
    last = now;
    if (state.playing) {
      state.t += dt * state.speed;
      if (state.t > duration) state.t = 0; // it loops
      show();
    }
    if (canvas.width !== Math.round(canvas.clientWidth * (window.devicePixelRatio || 1)) ||
        canvas.height !== Math.round(canvas.clientHeight * (window.devicePixelRatio || 1))) {
      resize();
      updateCamera();
    }
    updateTip(now);
    if (dirty) { drawScene(); dirty = false; }
    requestAnimationFrame(loop);
  }

  function project(p) { // world point (m) -> CSS pixels from the canvas's top left
    const m = viewProj, v = [p[0], p[1], p[2], 1], c = [0, 0, 0, 0];
    for (let r = 0; r < 4; r++) c[r] = m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2] + m[12 + r];
    return [(c[0] / c[3] + 1) / 2 * canvas.clientWidth, (1 - c[1] / c[3]) / 2 * canvas.clientHeight];
  }

  resize();
  updateCamera();
  show();
  // the hook browser tests use to check poses without timing
  window.maniplabPlayer = {
    get frame() { return state.frame; }, frames: meta.frames, fps: meta.fps, t0: meta.t0,
    get time() { return meta.t0 + state.frame / meta.fps; },
    get playing() { return state.playing; }, get drawn() { return state.drawn; },
    seek(t) { seek(t); drawScene(); dirty = false; return state.frame; },
    play() { setPlaying(true); }, pause() { setPlaying(false); },
    project,
    endEffector(run) { const p = runs[run].path, f = state.frame; return [p[3 * f], p[3 * f + 1], p[3 * f + 2]]; },
    nameAt,
  };
  requestAnimationFrame(loop);
})().catch((error) => {
  const box = document.getElementById("ml-error");
  box.textContent = `The replay could not start: ${error.message || error}`;
  box.style.display = "block";
  window.maniplabPlayer = { error: String(error.message || error) };
});
