// blinkcan front panel: draws the twins' snapshot() and sends what a person does.
"use strict";

// J1939 mode names its own colour codes (amber, yellow/green: §7a), shown as commanded
const LED = { off: "#111", red: "#ff3030", green: "#22dd44", blue: "#3a6bff", yellow: "#ffd820",
              cyan: "#20e0e0", magenta: "#e030e0", white: "#ffffff", amber: "#ffaa00",
              "yellow/green": "#b0e020" };
const BACKLIGHT = { off: null, red: "#ff3030", green: "#22dd44", blue: "#3a6bff", yellow: "#ffd820",
                    cyan: "#20e0e0", magenta: "#e030e0", white: "#f0f4ff", amber: "#ffaa00",
                    "yellow/green": "#b0e020" };
const hex = (n) => n.toString(16).toUpperCase().padStart(2, "0") + "h";
let latest = null;

// a device is named by its place in the panel (its "index"): two may share a node id (a
// keypad in J1939 mode keeps its CANopen node id beside one of another protocol)
async function act(id, action, extra) {
  const response = await fetch("/api/action", {
    method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify(Object.assign({ device: id, action }, extra || {})),
  });
  if (!response.ok) {
    const body = await response.json();
    document.getElementById("status").textContent = "refused: " + body.error;
  }
}

function element(tag, attributes, children) {
  const node = document.createElement(tag);
  Object.entries(attributes || {}).forEach(([k, v]) => {
    if (k === "text") node.textContent = v; else node.setAttribute(k, v);
  });
  (children || []).forEach((child) => node.appendChild(child));
  return node;
}

// Each device's elements are built once and then updated in place: a click's press and
// release always land on the same element, however often the state changes.
const views = new Map();  // device index -> { model, node, root, update(device) }
const current = new Map();  // device index -> latest snapshot

function headerView(id, node) {
  const power = element("button", { class: "power", "data-test": `power-${node}` });
  power.onclick = () => act(id, current.get(id).powered ? "power_off" : "power_on");
  const title = element("h2");
  const facts = element("div", { class: "facts" });
  return { parts: [power, title, facts], update(device) {
    power.textContent = device.powered ? "power off" : "power on";
    if (device.protocol === "j1939" && device.j1939) {  // spec/pkp-2600-si-j1939.md
      const j = device.j1939;
      title.textContent = `${device.title} J1939 ${hex(j.source_address)} · ${device.edition}`;
      facts.innerHTML = `<b data-test="protocol-${node}">J1939</b> · source address ` +
        `<b data-test="address-${node}">${hex(j.source_address)}</b> · identifier ` +
        `${hex(j.identifier)} · to ${hex(j.destination_address)} · claim ${j.address_claim} · ` +
        `${device.bitrate / 1000} kbit/s · heartbeat ${j.heartbeat_ms ? j.heartbeat_ms + " ms" : "off"}`;
      return;
    }
    title.textContent = `${device.title} ${hex(device.node_id)} · ${device.edition}`;
    facts.innerHTML = `NMT <b data-test="nmt-${node}">${device.nmt_state}</b> · ` +
      `${device.bitrate / 1000} kbit/s · heartbeat ${device.heartbeat_ms ? device.heartbeat_ms + " ms" : "off"}` +
      (device.quirks === "cia301" ? " · CiA 301 profile" : "");
  } };
}

// A rotary encoder: its ring LEDs drawn clockwise from six o'clock (as the model's face
// numbers them), turned by dragging up/down or scrolling; its cap is the key it also is.
const TICK_PIXELS = 12;
function knobView(id, encoder, cell) {
  const dots = encoder.ring_leds.map((led, i) => {
    const angle = (i / encoder.ring_leds.length) * 2 * Math.PI;  // clockwise from six o'clock
    const dot = element("div", { class: "ring-led", "data-test": `ring-led-${led}` });
    dot.style.left = `${50 - 44 * Math.sin(angle)}%`;
    dot.style.top = `${50 + 44 * Math.cos(angle)}%`;
    cell.appendChild(dot);
    return dot;
  });
  const counter = element("span", { class: "counter", "data-test": `counter-${encoder.number}` });
  cell.appendChild(counter);
  cell.classList.add("knob");
  const turn = (ticks) => { if (ticks) act(id, "turn", { encoder: encoder.number, ticks }); };
  cell.addEventListener("wheel", (event) => {
    event.preventDefault();
    turn(event.deltaY < 0 ? 1 : -1);  // scroll up: clockwise
  }, { passive: false });
  let dragY = null;
  let turned = false;
  cell.addEventListener("pointerdown", (event) => {
    event.preventDefault(); dragY = event.clientY; turned = false;
    cell.setPointerCapture(event.pointerId);  // a drag may leave the knob and still turn it
  });
  cell.addEventListener("pointermove", (event) => {
    if (dragY === null) return;
    const ticks = Math.trunc((dragY - event.clientY) / TICK_PIXELS);  // up: clockwise
    if (ticks) { dragY -= ticks * TICK_PIXELS; turned = true; turn(ticks); }
  });
  cell.addEventListener("pointerup", async () => {  // a click without turning pushes the knob
    if (dragY !== null && !turned) {
      await act(id, "press", { key: encoder.key });
      await act(id, "release", { key: encoder.key });
    }
    dragY = null;
  });
  cell.addEventListener("pointercancel", () => { dragY = null; });
  return { update(state, phase) {
    counter.textContent = state.counter;
    state.ring.forEach((led, i) => {
      const lit = phase === 0 ? led.on : led.on !== led.blink;  // blink: the on mask XOR blink
      dots[i].classList.toggle("lit", lit);
    });
  } };
}

// Inputs: a slider per analog input (0 to the face's full scale), and a switch per digital
// input showing its level; where one input is both (the face counts it in each), one row.
function inputsView(id, face) {
  const box = element("div", { class: "inputs" });
  const rows = [];
  for (let n = 0; n < Math.max(face.analog_inputs, face.digital_inputs); n++) {
    const row = { slider: null, value: element("span", { class: "volts" }), level: null };
    const parts = [element("span", { text: `IN${n}` })];
    if (n < face.analog_inputs) {
      row.slider = element("input", { type: "range", min: 0, max: face.analog_volts_max, step: 0.01,
                                      value: 0, "data-test": `analog-${n}` });
      row.slider.addEventListener("change", () =>
        act(id, "set_analog", { input: n, volts: parseFloat(row.slider.value) }));
      parts.push(row.slider, row.value);
    }
    if (n < face.digital_inputs) {
      row.level = element("button", { class: "level", "data-test": `digital-${n}` });
      row.level.onclick = () => act(id, "set_digital_input",
                                    { input: n, level: row.level.dataset.level === "high" ? 0 : 1 });
      parts.push(row.level);
    }
    rows.push(row);
    box.appendChild(element("label", {}, parts));
  }
  return { root: box, update(device) {
    (device.analog_inputs || []).forEach((input, n) => {
      const row = rows[n];
      if (!row) return;
      if (row.slider && document.activeElement !== row.slider) row.slider.value = input.volts;
      if (row.slider) row.value.textContent = `${input.volts.toFixed(2)} V`;
      if (row.level) {
        row.level.dataset.level = input.digital ? "high" : "low";
        row.level.textContent = `digital ${row.level.dataset.level}`;
        row.level.classList.toggle("input-high", input.digital);
      }
    });
  } };
}

function keypadView(id, node, face) {
  const head = headerView(id, node);
  const grid = element("div", { class: "keypad" });
  grid.style.gridTemplateColumns = `repeat(${Math.max(...face.grid.map((row) => row.length))}, 4.2rem)`;
  const cells = new Map();  // key number -> its elements
  for (const number of face.grid.flat()) {
    if (!number) { grid.appendChild(element("div", { class: "gap" })); continue; }
    // an LED where the face has one (a knob's cap has its ring instead)
    const led = face.led_keys.includes(number)
      ? element("div", { class: "led", "data-test": `led-${number}` }) : null;
    const cell = element("div", { class: "key", "data-test": `key-${number}` },
                         [...(led ? [led] : []), element("span", { class: "num", text: number })]);
    const press = (event) => { event.preventDefault(); act(id, "press", { key: number }); };
    const release = (event) => { event.preventDefault(); act(id, "release", { key: number }); };
    const encoder = face.encoders.find((e) => e.key === number);
    if (!encoder) {  // a knob is pushed by a click (knobView)
      cell.addEventListener("pointerdown", press);
      cell.addEventListener("pointerup", release);
      cell.addEventListener("pointerleave", (event) => {
        const key = current.get(id).keys[number - 1];
        if (key.pressed) release(event);
      });
    }
    const knob = encoder ? knobView(id, encoder, cell) : null;
    cells.set(number, { cell, led, knob, encoder });
    grid.appendChild(cell);
  }
  const inputs = inputsView(id, face);
  const footer = element("div", { class: "facts" });
  const root = element("div", { class: "device", "data-test": `device-${node}` },
                       [...head.parts, grid, inputs.root, footer]);
  return { model: null, root, update(device) {
    head.update(device);
    root.classList.toggle("off-power", !device.powered);
    const glow = BACKLIGHT[device.backlight.colour];
    const spread = 4 + device.backlight.level / 3;
    grid.style.boxShadow = glow && device.backlight.level > 0 ? `0 0 ${spread}px ${spread / 2}px ${glow}` : "none";
    // indicator brightness 0 is dark; 1..63 from dim to full (PKP §13)
    const level = device.indicator_brightness;
    const brightness = 0.15 + 0.85 * (level / 63);
    const phase = Math.floor(Date.now() / (1000 * device.blink_period_s / 2)) % 2;
    for (const state of device.encoders || []) {
      const view = [...cells.values()].find((c) => c.encoder && c.encoder.number === state.encoder);
      if (view) view.knob.update(state, phase);
    }
    inputs.update(device);
    device.keys.forEach((key) => {
      if (!cells.has(key.key)) return;
      const { cell, led } = cells.get(key.key);
      const colour = key.phases[phase];
      const shown = level > 0 ? colour : "off";
      cell.classList.toggle("pressed", key.pressed);
      cell.dataset.phases = key.phases.join(",");
      cell.dataset.colour = colour;
      cell.dataset.shown = shown;
      if (!led) return;
      led.style.background = LED[shown];
      led.style.opacity = shown === "off" ? 1 : brightness;
      led.style.boxShadow = shown === "off" ? "none" : `0 0 10px ${LED[shown]}`;
    });
    const extra = device.demo ? ` · DEMO: ${device.demo.step || "on"}` : "";
    const show = device.startup_show ? ` · startup show: ${device.startup_show.mode}` : "";
    footer.textContent = `backlight ${device.backlight.colour} ${device.backlight.level}/63 · ` +
      `LEDs ${device.indicator_brightness}/63${show}${extra}`;
  } };
}

function keyboxView(id, node, face) {
  const head = headerView(id, node);
  const grid = element("div", { class: "keybox" });
  const cells = [];
  for (let number = 1; number <= face.pins; number++) {
    const state = element("div", { class: "state", "data-test": `state-${number}` });
    const fuse = element("button", { "data-test": `fuse-${number}` });
    fuse.onclick = () => act(id, current.get(id).pins[number - 1].fuse === "blown"
                             ? "replace_fuse" : "blow_fuse", { pin: number });
    const input = element("button", { "data-test": `input-${number}` });
    input.onclick = () => act(id, current.get(id).pins[number - 1].input
                              ? "input_low" : "input_high", { pin: number });
    const lowside = element("div", { class: "lowside", text: "low side" });
    const cell = element("div", { class: "pin", "data-test": `pin-${number}` },
                         [element("div", { text: `pin ${number}` }), state, fuse, input, lowside]);
    cells.push({ state, fuse, input, lowside });
    grid.appendChild(cell);
  }
  const consumer = element("div", { class: "facts" });
  const root = element("div", { class: "device", "data-test": `device-${node}` },
                       [...head.parts, grid, consumer]);
  return { model: null, root, update(device) {
    head.update(device);
    root.classList.toggle("off-power", !device.powered);
    device.pins.forEach((pin, i) => {
      const view = cells[i];
      view.state.className = `state ${pin.state}`;
      view.state.textContent = pin.pwm_percent !== null ? `PWM ${pin.pwm_percent}%` : pin.state.toUpperCase();
      view.fuse.className = pin.fuse === "blown" ? "fuse-blown" : "";
      view.fuse.textContent = pin.fuse === "blown" ? "replace fuse" : "blow fuse";
      view.input.className = pin.input ? "input-high" : "";
      view.input.textContent = `input ${pin.input ? "high" : "low"}`;
      view.lowside.style.display = pin.low_side ? "" : "none";
    });
    const c = device.heartbeat_consumer;
    consumer.textContent = c && c.time_ms
      ? `watching node ${hex(c.node_id)} every ${c.time_ms} ms: ${c.state}` : "";
  } };
}

function render() {
  if (!latest) return;
  const devices = document.getElementById("devices");
  latest.devices.forEach((device) => {
    current.set(device.index, device);
    let view = views.get(device.index);
    if (!view || view.model !== device.model || view.node !== device.node_id) {
      if (view) view.root.remove();  // a keypad that moved to another node id: drawn again
      view = (device.face.keys ? keypadView : keyboxView)(device.index, device.node_id,
                                                           device.face);
      view.model = device.model;
      view.node = device.node_id;
      views.set(device.index, view);
      devices.appendChild(view.root);
    }
    view.update(device);
  });
  document.getElementById("frames").replaceChildren(...latest.frames.slice().reverse().map(
    (f) => element("li", { text: `${f.time.padStart(9)}  ${f.id.padStart(3)}  ${f.data.padEnd(23)}  ${f.text}` })));
}

const source = new EventSource("/api/events");
source.onmessage = (message) => {
  latest = JSON.parse(message.data);
  document.getElementById("status").textContent = "live";
  render();
};
source.onerror = () => { document.getElementById("status").textContent = "disconnected, retrying…"; };
setInterval(render, 125);  // blink phases move even when the state does not
