// The browser side of cumuli.Viewer (an anywidget ES module, no build step): shows the PNG
// frames the kernel sends, turns mouse drags and the wheel into messages, and binds its
// controls to the widget's traits. At most one mouse message is in flight: motion gathered
// while the kernel renders is sent as one message when the next frame arrives.

function slider(model, name, label, min, max, step, onInput) {
  const text = document.createElement("label");
  text.textContent = label;
  const input = document.createElement("input");
  Object.assign(input, { type: "range", min, max, step });
  input.className = `cumuli-${name.replace("_", "-")}`;
  input.value = model.get(name);
  const value = document.createElement("span");
  const show = () => { value.textContent = Number(model.get(name)).toFixed(step < 1 ? 2 : 0); };
  show();
  // Cheap settings follow the slider as it moves; those that need new light wait for release.
  input.addEventListener(onInput ? "input" : "change", () => {
    model.set(name, Number(input.value));
    model.save_changes();
  });
  model.on(`change:${name}`, () => { input.value = model.get(name); show(); });
  return [text, input, value];
}

function menu(model, name, label, options) {
  const text = document.createElement("label");
  text.textContent = label;
  const select = document.createElement("select");
  select.className = `cumuli-${name}`;
  for (const o of options) select.add(new Option(o, o));
  select.value = model.get(name);
  select.addEventListener("change", () => { model.set(name, select.value); model.save_changes(); });
  model.on(`change:${name}`, () => { select.value = model.get(name); });
  return [text, select, document.createElement("span")];
}

function render({ model, el }) {
  const root = document.createElement("div");
  root.className = "cumuli-viewer";
  const img = document.createElement("img");
  img.className = "cumuli-frame";
  img.draggable = false;
  img.width = model.get("width");
  const controls = document.createElement("div");
  controls.className = "cumuli-controls";
  const status = document.createElement("div");
  status.className = "cumuli-status";
  const error = document.createElement("div");
  error.className = "cumuli-error";

  let url = null;
  const showFrame = () => {
    const bytes = model.get("frame");
    if (!bytes || bytes.byteLength === 0) return;
    const next = URL.createObjectURL(new Blob([bytes], { type: "image/png" }));
    img.src = next;
    if (url) URL.revokeObjectURL(url);
    url = next;
  };
  // The state, written where a page (or a test) can read it.
  const showState = () => {
    const cam = model.get("camera") || {};
    root.dataset.frames = model.get("frames");
    root.dataset.frameKind = model.get("frame_kind");
    root.dataset.camera = JSON.stringify(cam);
    root.dataset.sun = JSON.stringify([model.get("sun_azimuth"), model.get("sun_elevation")]);
    const f = (v) => Number(v || 0).toFixed(1);
    status.textContent = `${model.get("status")} · camera az ${f(cam.azimuth)}° el ` +
      `${f(cam.elevation)}° dist ${f(cam.distance)} · sun az ${f(model.get("sun_azimuth"))}° ` +
      `el ${f(model.get("sun_elevation"))}°`;
    error.textContent = model.get("error");
  };

  // --- the mouse: one message in flight, the motion in between summed -----------------------
  let busy = false;
  let pending = null; // {type, dx, dy} or {type: "zoom", factor}
  let endAfter = false;
  let drag = null;
  let wheelTimer = null;
  const flush = () => {
    if (busy) return;
    if (pending) {
      busy = true;
      model.send(pending);
      pending = null;
    } else if (endAfter) {
      busy = true;
      endAfter = false;
      model.send({ type: "end" });
    }
  };
  const queue = (msg) => {
    if (pending && pending.type === msg.type && msg.type !== "zoom") {
      pending.dx += msg.dx;
      pending.dy += msg.dy;
    } else if (pending && pending.type === "zoom" && msg.type === "zoom") {
      pending.factor *= msg.factor;
    } else {
      if (pending) { const p = pending; pending = null; busy = false; model.send(p); busy = true; }
      pending = msg;
    }
    flush();
  };
  img.addEventListener("contextmenu", (e) => e.preventDefault());
  img.addEventListener("pointerdown", (e) => {
    drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2 };
    img.setPointerCapture(e.pointerId);
    img.classList.add("cumuli-dragging");
    e.preventDefault();
  });
  img.addEventListener("pointermove", (e) => {
    if (!drag) return;
    const scale = model.get("width") / (img.clientWidth || model.get("width"));
    const dx = (e.clientX - drag.x) * scale;
    const dy = (e.clientY - drag.y) * scale;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (dx !== 0 || dy !== 0) queue({ type: drag.pan ? "pan" : "orbit", dx, dy });
  });
  const release = (e) => {
    if (!drag) return;
    drag = null;
    img.classList.remove("cumuli-dragging");
    if (img.hasPointerCapture(e.pointerId)) img.releasePointerCapture(e.pointerId);
    endAfter = true;
    flush();
  };
  img.addEventListener("pointerup", release);
  img.addEventListener("pointercancel", release);
  img.addEventListener("wheel", (e) => {
    e.preventDefault();
    queue({ type: "zoom", factor: Math.exp(e.deltaY * 0.001) });
    clearTimeout(wheelTimer);
    wheelTimer = setTimeout(() => { endAfter = true; flush(); }, 250);
  }, { passive: false });

  model.on("change:frame", () => { showFrame(); });
  model.on("change:frames", () => { busy = false; showState(); flush(); });
  model.on("change:error", () => { busy = false; showState(); flush(); });
  for (const name of ["camera", "status", "sun_azimuth", "sun_elevation", "frame_kind"]) {
    model.on(`change:${name}`, showState);
  }

  const rows = [
    slider(model, "sun_azimuth", "sun azimuth (°)", -180, 180, 1, false),
    slider(model, "sun_elevation", "sun elevation (°)", -10, 90, 1, false),
    slider(model, "exposure", "exposure", 0.1, 4, 0.05, true),
    menu(model, "tonemap", "tone map", ["none", "aces", "reinhard"]),
    menu(model, "lighting", "lighting", ["paper", "physical"]),
    menu(model, "backend", "backend", ["cpu", "gl"]),
  ];
  if (model.get("duration") > 0) {
    rows.push(slider(model, "time", "time (s)", 0, model.get("duration"),
      Math.max(model.get("duration") / 200, 0.01), false));
  }
  for (const row of rows) controls.append(...row);
  root.append(img, status, error, controls);
  el.append(root);
  showFrame();
  showState();
  return () => { if (url) URL.revokeObjectURL(url); clearTimeout(wheelTimer); };
}

export default { render };
