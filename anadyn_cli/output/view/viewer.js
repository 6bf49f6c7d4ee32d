// anadyn view: draws the scene that anadyn computed (anadyn_cli/services/view.py).
// No kinematics here when a run is played: every body's 3x4 pose per frame comes
// from Python.  Live mode (no run) nests each body under its parent with its joint
// frame and turns it by its displacement, an affine function of the coordinates.
// URL hash: #empty hides the robot; #t=SECONDS or #t=end picks the time; #q=v1,v2,...
// sets the live sliders; #axes shows the body frames.
const HEADER = 120;           // px at least kept for the controls over the top of the view
const scene = JSON.parse(document.getElementById('anadyn-scene').textContent);
const status = document.getElementById('status');

function source(id, replacements) {
  let text = document.getElementById(id).textContent;
  for (const [from, to] of replacements) text = text.split(from).join(to);
  return URL.createObjectURL(new Blob([text], {type: 'text/javascript'}));
}

function bytes(b64) {
  const raw = atob(b64), out = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; i++) out[i] = raw.charCodeAt(i);
  return out.buffer;
}
const floats = (b64) => new Float32Array(bytes(b64));

function hashOptions() {
  const options = {};
  for (const item of location.hash.slice(1).split('&')) {
    const [key, value] = item.split('=');
    if (key) options[key] = value === undefined ? true : decodeURIComponent(value);
  }
  return options;
}

async function main() {
  const core = source('three-core', []);
  const three = source('three-module', [['"./three.core.min.js"', JSON.stringify(core)]]);
  const THREE = await import(three);
  const {OrbitControls} = await import(source('orbit-controls', [["'three'", JSON.stringify(three)]]));
  const options = hashOptions();
  const view = document.getElementById('view');
  const renderer = new THREE.WebGLRenderer({antialias: true, preserveDrawingBuffer: true});
  renderer.setPixelRatio(window.devicePixelRatio);
  view.appendChild(renderer.domElement);
  const world = new THREE.Scene();
  world.background = new THREE.Color(0xf4f5f7);
  const up = new THREE.Vector3(...scene.up);
  const camera = new THREE.PerspectiveCamera(40, 1, scene.extent / 100, scene.extent * 100);
  camera.up.copy(up);
  world.add(new THREE.HemisphereLight(0xffffff, 0x8d8d8d, 2.2));
  const sun = new THREE.DirectionalLight(0xffffff, 1.6);
  sun.position.copy(up.clone().multiplyScalar(3).add(new THREE.Vector3(1, 1.5, 0.5)));
  world.add(sun);
  const grid = new THREE.GridHelper(scene.extent * 4, 20, 0xb0b4ba, 0xd6d9de);
  grid.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), up);
  world.add(grid);

  // meshes: positions quantized to 16 bits over their box, indices 16 or 32 bits
  const geometries = scene.meshes.map((mesh) => mesh.parts.map((part) => {
    const u = new Uint16Array(bytes(part.positions));
    const positions = new Float32Array(u.length);
    for (let i = 0; i < u.length; i++) positions[i] = part.low[i % 3] + u[i] * part.step[i % 3];
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
    const index = part.wide ? new Uint32Array(bytes(part.indices)) : new Uint16Array(bytes(part.indices));
    geometry.setIndex(new THREE.BufferAttribute(index, 1));
    return {geometry, color: part.color};
  }));
  const material = (rgba) => new THREE.MeshStandardMaterial({
    color: new THREE.Color(rgba[0], rgba[1], rgba[2]), opacity: rgba[3], transparent: rgba[3] < 1,
    flatShading: true, metalness: 0.1, roughness: 0.6, side: THREE.DoubleSide});
  const bodies = scene.bodies.map((name) => {
    const group = new THREE.Group();
    group.name = name;
    group.matrixAutoUpdate = false;
    return group;
  });
  const ground = new THREE.Group();
  const robot = new THREE.Group();
  robot.add(ground);
  const backdrop = new THREE.Group();     // ground planes: drawn, not framed by the camera
  world.add(backdrop);
  for (const shape of scene.shapes) {
    const holder = new THREE.Group();
    holder.matrixAutoUpdate = false;
    holder.matrix.fromArray(shape.matrix).transpose();
    if (shape.kind === 'mesh') {
      for (const part of geometries[shape.mesh]) {
        const mesh = new THREE.Mesh(part.geometry, material(part.color || shape.color));
        mesh.scale.set(...shape.size);
        holder.add(mesh);
      }
    } else {
      let geometry;
      if (shape.kind === 'box') geometry = new THREE.BoxGeometry(...shape.size);
      else if (shape.kind === 'sphere') geometry = new THREE.SphereGeometry(shape.size[0], 24, 16);
      else geometry = new THREE.CylinderGeometry(shape.size[0], shape.size[0], shape.size[1], 24).rotateX(Math.PI / 2);
      holder.add(new THREE.Mesh(geometry, material(shape.color)));
    }
    (shape.backdrop ? backdrop : shape.body < 0 ? ground : bodies[shape.body]).add(holder);
  }
  const axes = bodies.map((body) => {
    const helper = new THREE.AxesHelper(scene.extent * 0.12);
    helper.visible = false;
    body.add(helper);
    return helper;
  });
  const arrows = scene.arrows.map((arrow) => {
    const helper = new THREE.ArrowHelper(new THREE.Vector3(0, 0, 1), new THREE.Vector3(), 1, arrow.color);
    robot.add(helper);
    return {helper, origins: floats(arrow.origins), vectors: floats(arrow.vectors)};
  });

  const q = floats(scene.q), n = scene.coordinates.length;
  const poses = scene.poses ? floats(scene.poses) : null;
  const b = scene.bodies.length, frames = scene.times.length;
  const m = new THREE.Matrix4();
  if (scene.live) {
    bodies.forEach((body, i) => (scene.live[i].parent < 0 ? robot : bodies[scene.live[i].parent]).add(body));
  } else {
    bodies.forEach((body) => robot.add(body));
  }
  world.add(robot);

  let pending = false, drawn = null;
  function draw() {           // on demand: after a change, never in a busy loop
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => {
      pending = false;
      renderer.render(world, camera);
      if (drawn) { drawn(); drawn = null; }
    });
  }
  const readout = document.getElementById('readout');
  function describe(values) {
    return scene.coordinates.map((name, i) => scene.units[i] === 'rad'
      ? `${name} = ${(values[i] * 180 / Math.PI).toFixed(1)}°` : `${name} = ${values[i].toFixed(3)} m`).join(', ');
  }
  function showFrame(k) {
    for (let i = 0; i < b; i++) {
      const o = (k * b + i) * 12;
      m.set(poses[o], poses[o + 1], poses[o + 2], poses[o + 3], poses[o + 4], poses[o + 5],
        poses[o + 6], poses[o + 7], poses[o + 8], poses[o + 9], poses[o + 10], poses[o + 11], 0, 0, 0, 1);
      bodies[i].matrix.copy(m);
      bodies[i].matrixWorldNeedsUpdate = true;
    }
    for (const arrow of arrows) {
      const o = new THREE.Vector3().fromArray(arrow.origins, 3 * k);
      const v = new THREE.Vector3().fromArray(arrow.vectors, 3 * k);
      const length = v.length();
      arrow.helper.visible = length > scene.extent * 1e-3;
      if (arrow.helper.visible) {
        arrow.helper.position.copy(o);
        arrow.helper.setDirection(v.normalize());
        arrow.helper.setLength(length, Math.min(length * 0.3, scene.extent * 0.05), scene.extent * 0.025);
      }
    }
    readout.textContent = `t = ${scene.times[k].toFixed(3)} s: ` + describe(q.subarray(k * n, k * n + n));
    draw();
  }
  function setLive(values) {
    scene.live.forEach((joint, i) => {
      let d = joint.offset;
      joint.gains.forEach((g, j) => { d += g * values[j]; });
      const motion = new THREE.Matrix4();
      const axis = new THREE.Vector3(...joint.axis);
      if (joint.type === 'prismatic') motion.makeTranslation(axis.multiplyScalar(d));
      else if (joint.type === 'revolute') motion.makeRotationAxis(axis, d);
      bodies[i].matrix.fromArray(joint.matrix).transpose().multiply(motion);
      bodies[i].matrixWorldNeedsUpdate = true;
    });
    readout.textContent = describe(values);
    draw();
  }

  const controls = document.getElementById('controls');
  let current = 0;
  if (scene.live) {
    const values = Array.from(scene.initial);
    const given = options.q ? options.q.split(',').map(Number) : [];
    given.forEach((v, i) => { if (i < n && Number.isFinite(v)) values[i] = v; });
    scene.coordinates.forEach((name, i) => {
      const label = document.createElement('label');
      label.textContent = name + ' ';
      const slider = document.createElement('input');
      Object.assign(slider, {type: 'range', min: scene.lower[i], max: scene.upper[i], step: 'any', value: values[i]});
      slider.id = 'q-' + name;
      slider.addEventListener('input', () => { values[i] = Number(slider.value); setLive(values); });
      label.appendChild(slider);
      controls.appendChild(label);
    });
    setLive(values);
  } else if (frames === 1) {
    showFrame(0);             // one pose, no controls
  } else {
    const slider = document.getElementById('time');
    slider.max = frames - 1;
    const play = document.getElementById('play');
    let playing = null;
    const seek = (k) => { current = k; slider.value = k; showFrame(k); };
    slider.addEventListener('input', () => seek(Number(slider.value)));
    play.addEventListener('click', () => {
      if (playing) { cancelAnimationFrame(playing); playing = null; play.textContent = 'play'; return; }
      play.textContent = 'pause';
      const span = scene.times[frames - 1] - scene.times[0];
      const start = performance.now() - (scene.times[current] - scene.times[0]) / scene.speed * 1000;
      const step = (now) => {
        const t = scene.times[0] + (now - start) / 1000 * scene.speed;
        let k = current;
        while (k < frames - 1 && scene.times[k + 1] <= t) k++;
        seek(k);
        if (t >= scene.times[0] + span) { playing = null; play.textContent = 'play'; return; }
        playing = requestAnimationFrame(step);
      };
      playing = requestAnimationFrame(step);
    });
    let k = 0;
    if (options.t === 'end') k = frames - 1;
    else if (options.t !== undefined) {
      const t = Number(options.t);
      while (k < frames - 1 && scene.times[k + 1] <= t) k++;
    }
    seek(k);
  }
  const toggle = document.getElementById('axes');
  toggle.checked = Boolean(options.axes);
  const showAxes = () => { axes.forEach((helper) => { helper.visible = toggle.checked; }); draw(); };
  toggle.addEventListener('change', showAxes);
  showAxes();

  // camera: looking at the robot's box from the front, a little above
  world.updateMatrixWorld(true);
  const box = new THREE.Box3().setFromObject(robot);
  const centre = box.isEmpty() ? new THREE.Vector3() : box.getCenter(new THREE.Vector3());
  const size = box.isEmpty() ? scene.extent : box.getSize(new THREE.Vector3()).length();
  const controlsOrbit = new OrbitControls(camera, renderer.domElement);
  controlsOrbit.target.copy(centre);
  const side = new THREE.Vector3(1, 0.7, 0.45).sub(up.clone().multiplyScalar(up.dot(new THREE.Vector3(1, 0.7, 0.45)))).normalize();
  camera.position.copy(centre).add(side.multiplyScalar(size * 1.7)).add(up.clone().multiplyScalar(size * 0.5));
  controlsOrbit.update();
  robot.visible = !options.empty;      // hidden after the camera is placed: the same view
  function resize() {          // the view is centred in the window below the controls
    const width = view.clientWidth, height = Math.max(view.clientHeight, 1);
    const top = Math.max(HEADER, document.querySelector('header').offsetHeight);
    renderer.setSize(width, height);
    camera.aspect = width / (height + top);
    camera.setViewOffset(width, height + top, 0, 0, width, height);
    camera.updateProjectionMatrix();
  }
  window.addEventListener('resize', () => { resize(); draw(); });
  resize();
  controlsOrbit.addEventListener('change', draw);
  drawn = () => {             // after the first picture: what tests and users read
    status.textContent = `drawn: ${scene.shapes.length} shapes on ${b} bodies, ` +
      (scene.live ? 'live' : `frame ${current + 1} of ${frames}`) + (robot.visible ? '' : ', robot hidden');
    status.dataset.state = 'drawn';
  };
  draw();
}

window.addEventListener('error', (event) => {
  status.textContent = 'error: ' + event.message;
  status.dataset.state = 'error';
});
main().catch((error) => {
  status.textContent = 'error: ' + error;
  status.dataset.state = 'error';
  console.error(error);
});
