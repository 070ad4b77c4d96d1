// The demonstration page: draws the live Scene, turns clicks into requests. No build step.
// The server decides everything (what a click means, whether it is allowed); the page only
// remembers the selected object and orientation between two clicks.
//
// A click's answer may come late (a busy machine), after the person has already selected the
// next object. So a goal click takes the selection with it when it is sent, and its answer
// never clears a selection made since: it only gives the selection back if the click was
// refused and nothing else was selected meanwhile. Nor does the page say "ready" while a
// click is on its way or on a state older than a click's answer: it waits for the server's
// state after that click.
//
// With a proposing policy (demo-ui --propose) the server sends its proposal for the world; the
// page highlights it (object, goal, an arrow between them) and holds it. Only a click sends
// anything: Accept sends the proposed pair, an object and a goal clicked send that pair.
"use strict";

const SVG = "http://www.w3.org/2000/svg";
// The episode fields of each task; a family's tasks come with the page's defaults
// (``family_tasks``: the fields its episodes are sized by).
const TASK_FIELDS = {
  multistack: ["blocks", "stacks"],
  file: [],
};

const page = {
  state: null, // the server's last snapshot
  selected: null, // id of the selected object
  orientation: null, // index of the chosen orientation, null: the goal's own
  bounds: null, // {episode, top: box, side: box} grown over the episode, metres
  formFilled: false,
  recorded: null, // demonstrations recorded, as last seen
  sending: 0, // clicks sent and not answered yet
  // The session version the last accepted click's answer named: a state older than that
  // predates the click (0: none; a new event stream, e.g. a restarted server, starts over).
  clickVersion: 0,
};

const $ = (id) => document.getElementById(id);

// --- talking to the server -------------------------------------------------------------------
async function post(path, body) {
  let reply;
  try {
    const response = await fetch(path, {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(body),
    });
    reply = await response.json();
  } catch (error) {
    reply = { ok: false, error: `no answer from the page's server (${error})` };
  }
  if (!reply.ok) notice("error", reply.error);
  return reply;
}

function listen() {
  const events = new EventSource("/api/events");
  events.onopen = () => {
    page.clickVersion = 0;
    setConnection("live", "live");
  };
  events.onerror = () => setConnection("lost", "connection lost, retrying…");
  events.onmessage = (event) => {
    page.state = JSON.parse(event.data);
    render();
  };
}

function setConnection(state, text) {
  const element = $("connection");
  element.dataset.state = state;
  element.textContent = text;
}

function notice(level, text) {
  const element = $("notice");
  element.dataset.level = level;
  element.textContent = text;
}

// --- clicks ----------------------------------------------------------------------------------
function clickObject(id) {
  page.selected = page.selected === id ? null : id;
  renderSelection();
  drawViews();
}

async function clickGoal(id) {
  const click = { object_id: page.selected, goal_id: id, orientation_index: page.orientation };
  page.selected = null; // taken by this click: the next object may be selected at once
  page.orientation = null;
  renderSelection();
  renderOrientations();
  drawViews();
  const reply = await sendAction(click);
  if (!reply.ok) {
    // Refused: the person may try another goal with the same object, unless they have
    // moved on to another one (or another orientation) meanwhile.
    if (page.selected === null && click.object_id && objectInScene(click.object_id)) {
      page.selected = click.object_id;
    }
    if (page.orientation === null) page.orientation = click.orientation_index;
    renderSelection();
    renderOrientations();
    drawViews();
  }
}

// A fixture's button sends the family action its kind takes (the page's ``fixture_actions``).
async function clickFixture(fixtureId, action) {
  await sendAction({ family_action: action, object_id: fixtureId });
}

function currentProposal() {
  const proposer = page.state && page.state.proposer;
  return proposer ? proposer.proposal : null;
}

async function acceptProposal() {
  const proposal = currentProposal();
  if (!proposal || page.sending > 0) return;
  page.selected = null;
  page.orientation = null;
  renderSelection();
  renderOrientations();
  const click =
    proposal.family_action !== null
      ? { family_action: proposal.family_action, object_id: proposal.object_id }
      : {
          object_id: proposal.object_id,
          goal_id: proposal.goal_id,
          orientation_index: proposal.orientation_index,
        };
  await sendAction(click);
}

// The robot is not "ready" from the click until the page has seen the state after it.
async function sendAction(body) {
  page.sending += 1;
  renderRobot();
  const reply = await post("/api/action", body);
  page.sending -= 1;
  if (reply.ok && Number.isInteger(reply.version)) {
    page.clickVersion = Math.max(page.clickVersion, reply.version);
  }
  renderRobot();
  renderProposal();
  return reply;
}

function objectInScene(id) {
  const scene = page.state && page.state.scene;
  return !scene || scene.objects.some((o) => o.id === id);
}

async function startEpisode(event) {
  event.preventDefault();
  const form = new FormData($("episode-form"));
  const task = form.get("task");
  const body = { task, seed: Number(form.get("seed")) };
  const fields = TASK_FIELDS[task] || ["blocks"];
  for (const name of fields) {
    const value = form.get(name);
    body[name] = name === "blocks" || name === "stacks" || name === "objects" ? Number(value) : value;
  }
  page.selected = null;
  page.orientation = null;
  const reply = await post("/api/episode", body);
  if (reply.ok) notice("info", `episode ${reply.episode_id}: click an object, then where it goes`);
  renderSelection();
}

// --- rendering -------------------------------------------------------------------------------
function render() {
  const state = page.state;
  fillForm(state.defaults);
  const episode = state.episode;
  $("episode").textContent = episode
    ? `${episode.id} · ${episode.task ?? "?"} · seed ${episode.seed ?? "?"}`
    : "none yet: start one";
  const counted = episode && (state.defaults.counted || {})[episode.task];
  const done = counted
    ? `${episode?.objects_placed}/${episode?.objects_total} ${counted} in place`
    : `${episode?.goals_filled}/${episode?.goals_total} goals filled`;
  $("progress").textContent = episode
    ? `${done} · ${episode.steps_recorded} ` +
      `steps demonstrated · ${episode.refused} refused` +
      (state.proposer ? ` · ${episode.accepted} accepted · ${episode.corrected} corrected` : "") +
      (episode.ended ? (episode.success ? " · success" : " · failed") : "")
    : "–";
  renderRobot();
  renderProposal();
  const recorded = state.recorded;
  $("recorded").textContent =
    `${recorded.demonstrations} demonstration${recorded.demonstrations === 1 ? "" : "s"} ` +
    `(${recorded.decisions} decisions) → ${recorded.file}`;
  if (page.recorded !== null && recorded.demonstrations > page.recorded) {
    $("seed").value = Number($("seed").value) + 1; // the next demonstration: another layout
  }
  page.recorded = recorded.demonstrations;
  renderMessages(state.messages);
  const fixtures = state.scene ? state.scene.fixtures : [];
  renderFixtureButtons(fixtures, state.defaults.fixture_actions || {});
  // Orientations matter where goals stand in a fixture (a rack's slots), not for every fixture.
  $("orientations").hidden = !(state.scene && state.scene.goals.some((g) => g.fixture));
  if (page.selected && !objectInScene(page.selected)) page.selected = null;
  renderSelection();
  renderOrientations();
  drawViews();
}

// One button per fixture whose kind takes a family action, named by the fixture and its state.
function renderFixtureButtons(fixtures, actions) {
  const box = $("fixture-buttons");
  const operable = fixtures.filter((f) => actions[f.kind]);
  $("fixtures").hidden = operable.length === 0;
  const ids = operable.map((f) => f.id).join(" ");
  if (box.dataset.ids !== ids) {
    box.dataset.ids = ids;
    box.replaceChildren();
    for (const fixture of operable) {
      const button = document.createElement("button");
      button.type = "button";
      button.id = `fixture-${fixture.id}`;
      button.dataset.fixture = fixture.id;
      button.dataset.action = actions[fixture.kind];
      button.addEventListener("click", () => clickFixture(fixture.id, actions[fixture.kind]));
      box.appendChild(button);
    }
  }
  for (const fixture of operable) {
    const button = $(`fixture-${fixture.id}`);
    button.textContent = `${fixture.id}: ${actions[fixture.kind]} (${fixture.open ? "out" : "in"})`;
    button.dataset.open = String(!!fixture.open);
  }
}

function renderRobot() {
  const state = page.state;
  const behind = page.sending > 0 || (state !== null && state.version < page.clickVersion);
  const busy = behind ? "your click is on its way to the robot" : state?.busy;
  const robot = $("robot-state");
  if (busy === undefined) return; // no state yet: the page's "–"
  robot.dataset.ready = String(busy === null);
  robot.textContent = busy === null ? "ready: your move" : busy;
}

function renderProposal() {
  const proposer = page.state && page.state.proposer;
  const box = $("proposal");
  box.hidden = !proposer;
  if (!proposer) return;
  const proposal = proposer.proposal;
  box.dataset.object = proposal ? proposal.object_id : "";
  box.dataset.goal = proposal ? proposal.goal_id : "";
  $("proposal-text").textContent = proposal
    ? `${proposer.policy} proposes ${proposal.text}`
    : proposer.thinking
      ? `${proposer.policy} is deciding…`
      : `${proposer.policy}: no proposal now`;
  $("accept").disabled = !proposal || page.sending > 0;
  for (const button of document.querySelectorAll("#fixture-buttons button")) {
    const proposed = !!proposal && proposal.family_action !== null &&
      proposal.object_id === button.dataset.fixture;
    button.classList.toggle("proposed", proposed);
  }
}

function fillForm(defaults) {
  if (page.formFilled || !defaults) return;
  page.formFilled = true;
  for (const [task, fields] of Object.entries(defaults.family_tasks || {})) {
    TASK_FIELDS[task] = fields;
    if (![...$("task").options].some((o) => o.value === task)) {
      const option = document.createElement("option");
      option.value = task;
      option.textContent = task;
      $("task").appendChild(option);
    }
  }
  if (defaults.task === "file") {
    const option = document.createElement("option");
    option.value = "file";
    option.textContent = `file: ${defaults.task_file}`;
    $("task").appendChild(option);
  }
  $("task").value = defaults.task;
  $("blocks").value = defaults.blocks;
  $("stacks").value = defaults.stacks;
  if (defaults.objects) $("objects").value = defaults.objects;
  if (defaults.preference) $("preference").value = defaults.preference;
  $("seed").value = defaults.seed;
  showTaskFields();
}

function showTaskFields() {
  const task = $("task").value;
  const fields = TASK_FIELDS[task] || ["blocks"];
  for (const label of document.querySelectorAll("label[data-for]")) {
    label.hidden = !fields.includes(label.dataset.for);
  }
}

function renderMessages(messages) {
  const list = $("messages");
  list.replaceChildren();
  for (const message of messages.slice(-8).reverse()) {
    const item = document.createElement("li");
    item.dataset.level = message.level;
    item.textContent = message.text;
    list.appendChild(item);
  }
  const last = messages[messages.length - 1];
  if (last && last.time !== page.lastMessageTime) {
    page.lastMessageTime = last.time;
    notice(last.level, last.text);
  }
}

function renderSelection() {
  const text = page.selected
    ? `${page.selected} selected: click where it goes`
    : "Click an object, then where it goes.";
  $("selection-text").textContent = text;
  $("selection").dataset.object = page.selected ?? "";
  $("clear-selection").hidden = !page.selected;
}

function renderOrientations() {
  const box = $("orientation-buttons");
  const names = page.state ? page.state.orientations : [];
  if (box.childElementCount !== names.length + 1) {
    box.replaceChildren();
    const choices = [[null, "the slot's own"], ...names.map((name, index) => [index, `${index} ${name}`])];
    for (const [index, label] of choices) {
      const button = document.createElement("button");
      button.type = "button";
      button.textContent = label;
      button.dataset.orientation = index === null ? "auto" : String(index);
      button.addEventListener("click", () => {
        page.orientation = index;
        renderOrientations();
      });
      box.appendChild(button);
    }
  }
  for (const button of box.children) {
    const chosen = page.orientation === null ? "auto" : String(page.orientation);
    button.classList.toggle("chosen", button.dataset.orientation === chosen);
  }
}

// --- the two views ---------------------------------------------------------------------------
// Drawn in millimetres (the scene is in metres): SVG user units that fonts and strokes suit.
// Top view: screen right is the robot's right (-y), screen up is forward (+x).
// Side view, from the robot: screen right is -y, screen up is +z.
const MM = 1000;
const VIEWS = {
  top: { svg: "top-view", u: (p) => -p.y * MM, v: (p) => -p.x * MM, dv: 0, origin: true },
  side: { svg: "side-view", u: (p) => -p.y * MM, v: (p) => -p.z * MM, dv: 2, origin: false },
};

function drawViews() {
  const scene = page.state && page.state.scene;
  for (const [name, view] of Object.entries(VIEWS)) {
    const svg = $(view.svg);
    svg.replaceChildren();
    if (!scene) continue;
    const box = growBounds(name, view, scene);
    svg.setAttribute("viewBox", `${box.u0} ${box.v0} ${box.u1 - box.u0} ${box.v1 - box.v0}`);
    drawGround(svg, view, box);
    if (name === "top") drawRacks(svg, view, scene);
    else drawRackLevels(svg, view, scene, box);
    for (const item of drawOrder(scene, name)) drawItem(svg, view, item);
    drawProposal(svg, view, scene);
  }
}

// The proposed move as an arrow from the object to its goal, in the top view (clicks go
// through it; in the side view, where things line up behind each other, the halos say it).
function drawProposal(svg, view, scene) {
  const proposal = currentProposal();
  if (!proposal || proposal.family_action !== null || !view.origin) return;
  const item = scene.objects.find((o) => o.id === proposal.object_id);
  const goal = scene.goals.find((g) => g.id === proposal.goal_id);
  if (!item || !goal) return;
  const defs = element("defs", {}, svg);
  const marker = element(
    "marker",
    { id: `${view.svg}-head`, viewBox: "0 0 10 10", refX: 9, refY: 5, markerWidth: 6, markerHeight: 6, orient: "auto-start-reverse" },
    defs,
  );
  element("path", { d: "M 0 0 L 10 5 L 0 10 z", class: "proposal-head" }, marker);
  element(
    "line",
    { class: "proposal-arrow", x1: view.u(item), y1: view.v(item), x2: view.u(goal), y2: view.v(goal), "marker-end": `url(#${view.svg}-head)` },
    svg,
  );
}

// Extents along the view's two axes, mm (the extent array is along world x, y, z, metres).
function extents(view, item) {
  return [item.extent[1] * MM, item.extent[view.dv] * MM];
}

function growBounds(name, view, scene) {
  if (!page.bounds || page.bounds.episode !== scene.episode_id) {
    page.bounds = { episode: scene.episode_id };
  }
  const points = [];
  for (const item of [...scene.objects, ...scene.goals]) {
    const [eu, ev] = extents(view, item);
    points.push([view.u(item) - eu / 2, view.v(item) - ev / 2], [view.u(item) + eu / 2, view.v(item) + ev / 2]);
  }
  for (const fixture of scene.fixtures) {
    const [eu, ev] = fixture.extent ? extents(view, fixture) : [0, 0];
    points.push([view.u(fixture) - eu / 2, view.v(fixture) - ev / 2], [view.u(fixture) + eu / 2, view.v(fixture) + ev / 2]);
  }
  points.push([0, 0]); // the robot (top view) or the table under it (side view)
  let box = page.bounds[name];
  for (const [u, v] of points) {
    if (!box) box = { u0: u, u1: u, v0: v, v1: v };
    box.u0 = Math.min(box.u0, u);
    box.u1 = Math.max(box.u1, u);
    box.v0 = Math.min(box.v0, v);
    box.v1 = Math.max(box.v1, v);
  }
  page.bounds[name] = box;
  const pad = 50;
  return { u0: box.u0 - pad, u1: box.u1 + pad, v0: box.v0 - pad, v1: box.v1 + pad };
}

// Things seen from above (or from the robot) cover what lies under (or behind) them, so they
// are drawn in that order; free goals come last: where a person may put something is never
// hidden by what stands elsewhere. Among free goals seen from above, a stack's lowest (the
// next to fill) is on top, while a fixture's goals are seen as they are (the top rack's slots
// over the bottom rack's).
function drawOrder(scene, name) {
  const depth = name === "top" ? (p) => p.z : (p) => -p.x;
  const things = [
    ...scene.goals.filter((g) => g.filled).map((g) => ({ ...g, kind: "goal" })),
    ...scene.objects.map((o) => ({ ...o, kind: "object" })),
  ].sort((a, b) => depth(a) - depth(b) || (a.kind === "goal" ? -1 : 1));
  const freeDepth = name === "top" ? (g) => (g.fixture ? g.z : -g.z) : depth;
  const free = scene.goals
    .filter((g) => !g.filled)
    .map((g) => ({ ...g, kind: "goal" }))
    .sort((a, b) => freeDepth(a) - freeDepth(b));
  return [...things, ...free];
}

function element(tag, attributes, parent) {
  const node = document.createElementNS(SVG, tag);
  for (const [key, value] of Object.entries(attributes)) node.setAttribute(key, value);
  if (parent) parent.appendChild(node);
  return node;
}

function drawGround(svg, view, box) {
  if (view.origin) {
    const robot = element("g", { class: "robot" }, svg);
    element("circle", { cx: 0, cy: 0, r: 40 }, robot);
    element("text", { x: 0, y: 6, "text-anchor": "middle" }, robot).textContent = "robot";
  } else {
    element("line", { class: "table", x1: box.u0, x2: box.u1, y1: 0, y2: 0 }, svg);
  }
}

function rackBox(scene, rack, view) {
  const slots = scene.goals.filter((g) => g.fixture === rack.id);
  let u0 = Infinity, u1 = -Infinity, v0 = Infinity, v1 = -Infinity;
  for (const slot of [...slots, { ...rack, extent: [0.02, 0.02, 0.02] }]) { // and its handle
    const [eu, ev] = extents(view, slot);
    u0 = Math.min(u0, view.u(slot) - eu / 2);
    u1 = Math.max(u1, view.u(slot) + eu / 2);
    v0 = Math.min(v0, view.v(slot) - ev / 2);
    v1 = Math.max(v1, view.v(slot) + ev / 2);
  }
  return { u0: u0 - 10, u1: u1 + 10, v0: v0 - 10, v1: v1 + 10 };
}

function rackName(fixture) {
  const state = "open" in fixture ? ` (${fixture.open ? "out" : "in"})` : ` (${fixture.kind})`;
  return `${fixture.id.replace(/_/g, " ")}${state}`;
}

// A fixture its family gives a size (a board, a wall) is drawn as its own box, in
// both views, under everything else; named in its tooltip, not in words on the page.
function drawFixtureBox(svg, view, fixture) {
  const [eu, ev] = extents(view, fixture).map((e) => Math.max(e, 4));
  const group = element("g", { class: "fixture-box", "data-fixture": fixture.id }, svg);
  element("rect", { x: view.u(fixture) - eu / 2, y: view.v(fixture) - ev / 2, width: eu, height: ev }, group);
  element("title", {}, group).textContent = rackName(fixture);
}

function drawRacks(svg, view, scene) {
  // The lower fixture under the upper one (the bottom rack under the top one).
  const racks = [...scene.fixtures].sort((a, b) => a.z - b.z);
  for (const rack of racks) {
    if (rack.extent) {
      drawFixtureBox(svg, view, rack);
      continue;
    }
    const box = rackBox(scene, rack, view);
    const group = element("g", { class: `rack ${rack.open ? "open" : "closed"}`, "data-rack": rack.id }, svg);
    element("rect", { x: box.u0, y: box.v0, width: box.u1 - box.u0, height: box.v1 - box.v0 }, group);
    element("circle", { class: "handle", cx: view.u(rack), cy: view.v(rack), r: 8 }, group);
    element("text", { x: box.u0, y: box.v0 - 8 }, group).textContent = rackName(rack);
  }
}

function drawRackLevels(svg, view, scene, box) {
  for (const rack of scene.fixtures) {
    if (rack.extent) {
      drawFixtureBox(svg, view, rack);
      continue;
    }
    const level = view.v(rack);
    const group = element("g", { class: `rack ${rack.open ? "open" : "closed"}` }, svg);
    element("line", { x1: box.u0 + 20, x2: box.u1 - 20, y1: level, y2: level }, group);
    element("text", { x: box.u0 + 20, y: level + 18 }, group).textContent = rackName(rack);
  }
}

function drawItem(svg, view, item) {
  const [eu, ev] = extents(view, item).map((e) => Math.max(e, 12));
  const classes = [item.kind, `cat-${item.category}`];
  if (item.filled) classes.push("filled");
  if (!item.visible) classes.push("hidden");
  if (item.kind === "object" && item.id === page.selected) classes.push("selected");
  const proposal = currentProposal();
  const proposed =
    proposal && proposal.family_action === null &&
    item.id === (item.kind === "object" ? proposal.object_id : proposal.goal_id);
  if (proposed) classes.push("proposed");
  const group = element("g", { class: classes.join(" "), "data-id": item.id }, svg);
  const rect = element(
    "rect",
    { x: view.u(item) - eu / 2, y: view.v(item) - ev / 2, width: eu, height: ev, rx: item.category === "bowl" ? Math.min(eu, ev) / 3 : 2 },
    group,
  );
  // The task's own colour: an object is filled with it, a goal outlined in what it accepts.
  if (item.fill) rect.style[item.kind === "object" ? "fill" : "stroke"] = item.fill;
  if (proposed) {
    const halo = 7;
    element(
      "rect",
      { class: "halo", x: view.u(item) - eu / 2 - halo, y: view.v(item) - ev / 2 - halo, width: eu + 2 * halo, height: ev + 2 * halo, rx: 4 },
      group,
    );
  }
  const orientation = page.state.orientations[item.orientation];
  const words = item.kind === "object" ? item.label : item.accepts && `accepts ${item.accepts}`;
  element("title", {}, group).textContent =
    `${item.id} (${item.category}${item.kind === "goal" ? " goal" : ""}` +
    `${item.filled ? ", filled" : ""}, ${orientation}${words ? `, ${words}` : ""}) at ` +
    `x ${item.x.toFixed(3)} y ${item.y.toFixed(3)} z ${item.z.toFixed(3)} m`;
  if (item.kind === "object" && item.visible && (view.svg === "top-view" || !item.fixture)) {
    const label = element("text", { x: view.u(item), y: view.v(item) + 4, "text-anchor": "middle" }, group);
    label.textContent = item.id.replace(/^(block|cover|plate|bowl)_/, (_, kind) => kind[0]);
  }
  if (item.tag && item.visible && view.svg === "top-view") {
    const caption = element("text", { class: "attributes", x: view.u(item), y: view.v(item) + ev / 2 + 14, "text-anchor": "middle" }, group);
    caption.textContent = item.tag;
  }
  group.addEventListener("click", (event) => {
    event.stopPropagation();
    if (item.kind === "object") clickObject(item.id);
    else clickGoal(item.id);
  });
}

// --- wiring ----------------------------------------------------------------------------------
$("episode-form").addEventListener("submit", startEpisode);
$("task").addEventListener("change", showTaskFields);
$("clear-selection").addEventListener("click", () => clickObject(page.selected));
$("accept").addEventListener("click", acceptProposal);
showTaskFields();
renderOrientations();
listen();
