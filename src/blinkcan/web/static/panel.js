// blinkcan front panel: draws the twins' snapshot() and sends what a person does.
"use strict";

const LED = { off: "#111", red: "#ff3030", green: "#22dd44", blue: "#3a6bff", yellow: "#ffd820",
              cyan: "#20e0e0", magenta: "#e030e0", white: "#ffffff" };
const BACKLIGHT = { off: null, red: "#ff3030", green: "#22dd44", blue: "#3a6bff", yellow: "#ffd820",
                    cyan: "#20e0e0", magenta: "#e030e0", white: "#f0f4ff", amber: "#ffaa00",
                    yellow_green: "#b0e020" };
const hex = (n) => n.toString(16).toUpperCase().padStart(2, "0") + "h";
let latest = null;

async function act(node, action, extra) {
  const response = await fetch("/api/action", {
    method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify(Object.assign({ node, action }, extra || {})),
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

function header(device) {
  const power = element("button", { class: "power", "data-test": `power-${device.node_id}`,
                                    text: device.powered ? "power off" : "power on" });
  power.onclick = () => act(device.node_id, device.powered ? "power_off" : "power_on");
  const title = device.kind === "keypad"
    ? `PKP-2600-SI keypad ${hex(device.node_id)} · generation ${device.generation === "1.5" ? "2 (manual rev 1.5)" : "1 (manual rev 1.1)"}`
    : `Keybox ${hex(device.node_id)}`;
  const facts = element("div", { class: "facts" });
  facts.innerHTML = `NMT <b data-test="nmt-${device.node_id}">${device.nmt_state}</b> · ` +
    `${device.bitrate / 1000} kbit/s · heartbeat ${device.heartbeat_ms ? device.heartbeat_ms + " ms" : "off"}` +
    (device.quirks === "cia301" ? " · CiA 301 profile" : "");
  return [power, element("h2", { text: title }), facts];
}

function keypad(device) {
  const box = element("div", { class: "device" + (device.powered ? "" : " off-power"),
                               "data-test": `device-${device.node_id}` }, header(device));
  const grid = element("div", { class: "keypad" });
  const glow = BACKLIGHT[device.backlight.colour];
  if (glow && device.backlight.level > 0) {
    const spread = 4 + device.backlight.level / 3;
    grid.style.boxShadow = `0 0 ${spread}px ${spread / 2}px ${glow}`;
  }
  const brightness = 0.35 + 0.65 * (device.indicator_brightness / 63);
  const phase = Math.floor(Date.now() / (1000 * device.blink_period_s / 2)) % 2;
  device.keys.forEach((key) => {
    const cell = element("div", { class: "key" + (key.pressed ? " pressed" : ""),
                                  "data-test": `key-${key.key}`, "data-colour": key.phases[phase],
                                  "data-phases": key.phases.join(",") });
    const led = element("div", { class: "led" });
    const colour = key.phases[phase];
    led.style.background = LED[colour];
    led.style.opacity = colour === "off" ? 1 : brightness;
    if (colour !== "off") led.style.boxShadow = `0 0 10px ${LED[colour]}`;
    cell.append(led, element("span", { class: "num", text: key.key }));
    const press = (event) => { event.preventDefault(); act(device.node_id, "press", { key: key.key }); };
    const release = (event) => { event.preventDefault(); act(device.node_id, "release", { key: key.key }); };
    cell.addEventListener("pointerdown", press);
    cell.addEventListener("pointerup", release);
    cell.addEventListener("pointerleave", (event) => { if (key.pressed) release(event); });
    grid.appendChild(cell);
  });
  box.appendChild(grid);
  const extra = device.demo ? ` · DEMO: ${device.demo.step || "on"}` : "";
  const show = device.startup_show ? ` · startup show: ${device.startup_show.mode}` : "";
  box.appendChild(element("div", { class: "facts", text:
    `backlight ${device.backlight.colour} ${device.backlight.level}/63 · LEDs ${device.indicator_brightness}/63${show}${extra}` }));
  return box;
}

function keybox(device) {
  const box = element("div", { class: "device" + (device.powered ? "" : " off-power"),
                               "data-test": `device-${device.node_id}` }, header(device));
  const grid = element("div", { class: "keybox" });
  device.pins.forEach((pin) => {
    const label = pin.pwm_percent !== null ? `PWM ${pin.pwm_percent}%` : pin.state.toUpperCase();
    const fuse = element("button", { class: pin.fuse === "blown" ? "fuse-blown" : "",
                                     "data-test": `fuse-${pin.pin}`,
                                     text: pin.fuse === "blown" ? "replace fuse" : "blow fuse" });
    fuse.onclick = () => act(device.node_id, pin.fuse === "blown" ? "replace_fuse" : "blow_fuse", { pin: pin.pin });
    const input = element("button", { class: pin.input ? "input-high" : "", "data-test": `input-${pin.pin}`,
                                      text: `input ${pin.input ? "high" : "low"}` });
    input.onclick = () => act(device.node_id, pin.input ? "input_low" : "input_high", { pin: pin.pin });
    const cell = element("div", { class: "pin", "data-test": `pin-${pin.pin}` }, [
      element("div", { text: `pin ${pin.pin}` }),
      element("div", { class: `state ${pin.state}`, "data-test": `state-${pin.pin}`, text: label }),
      fuse, input,
    ]);
    if (pin.low_side) cell.appendChild(element("div", { class: "lowside", text: "low side" }));
    grid.appendChild(cell);
  });
  box.appendChild(grid);
  if (device.heartbeat_consumer && device.heartbeat_consumer.time_ms) {
    const c = device.heartbeat_consumer;
    box.appendChild(element("div", { class: "facts",
      text: `watching node ${hex(c.node_id)} every ${c.time_ms} ms: ${c.state}` }));
  }
  return box;
}

function render() {
  if (!latest) return;
  const devices = document.getElementById("devices");
  devices.replaceChildren(...latest.devices.map((d) => (d.kind === "keypad" ? keypad(d) : keybox(d))));
  document.getElementById("frames").replaceChildren(...latest.frames.slice().reverse().map(
    (f) => element("li", { text: `${f.id.padStart(3)}  ${f.data.padEnd(23)}  ${f.text}` })));
}

const source = new EventSource("/api/events");
source.onmessage = (message) => {
  latest = JSON.parse(message.data);
  document.getElementById("status").textContent = "live";
  render();
};
source.onerror = () => { document.getElementById("status").textContent = "disconnected, retrying…"; };
setInterval(render, 125);  // blink phases move even when the state does not
