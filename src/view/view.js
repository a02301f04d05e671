// amhv's page of an edited scene (docs/scenes.md, "The page"). Plays view/scene.js (scene.glb,
// base64: a file:// page may not fetch files) with three.js, and plots each key segment's solution
// group from view/data.js (result.json, transforms.json's segments and the groups' members, as the
// output folder holds them). Clicking a member shows B at that pose over the key segment and the
// scene lines that make the DP choose it. `#frame=N` in the address opens frame N; `#pick=S,R`
// picks plotted member R of key segment S as a click does.
(function () {
  'use strict';
  const data = window.AMHV_DATA;
  const statusLine = document.getElementById('status');
  const fps = data.fps;
  const frameCount = data.transforms.frames;
  const degrees = Math.PI / 180;

  function fail(message) {
    statusLine.textContent = 'error: ' + message;
    console.error(message);
  }
  window.addEventListener('error', (e) => fail(e.message));

  // ---- the 3D player ----
  const container = document.getElementById('player');
  const renderer = new THREE.WebGLRenderer({ antialias: true });
  renderer.setPixelRatio(1);
  container.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xf6f6f4);
  const camera = new THREE.PerspectiveCamera(40, 1, 0.05, 500);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8a8a, 0.9));
  const sun = new THREE.DirectionalLight(0xffffff, 0.6);
  sun.position.set(3, 8, 5);
  scene.add(sun);
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  let mixer = null, playing = false, time = 0, shown = 0, dirty = true;  // drawn only when something changed
  const bNodes = [];   // per output frame: B's node
  const poseGroups = [];  // per key segment: the group B's key frames hang in (moved to a clicked pose)

  function resize() {
    const w = container.clientWidth, h = container.clientHeight;
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(1, h);
    camera.updateProjectionMatrix();
    dirty = true;
  }
  window.addEventListener('resize', resize);

  // The scene's (x, y, z) in glTF's axes (x, z, -y).
  function gl(x, y, z) { return new THREE.Vector3(x, z, -y); }

  function frameCamera() {
    const box = new THREE.Box3();
    for (const r of data.roots) box.expandByPoint(gl(r[0], r[1], 0)), box.expandByPoint(gl(r[2], r[3], 0));
    box.expandByPoint(new THREE.Vector3(box.min.x, 1.8, box.min.z));
    const centre = box.getCenter(new THREE.Vector3()), size = box.getSize(new THREE.Vector3());
    const reach = Math.max(2.5, size.x, size.z);
    const grid = new THREE.GridHelper(Math.ceil(reach * 2 + 4), Math.ceil(reach * 2 + 4) * 2, 0x999999, 0xd0d0d0);
    grid.position.set(Math.round(centre.x), 0, Math.round(centre.z));
    scene.add(grid);
    controls.target.set(centre.x, 0.9, centre.z);
    camera.position.set(centre.x + reach * 0.9, reach * 0.8 + 1, centre.z + reach * 1.2);
    controls.update();
  }

  function segmentOf(k) {
    for (const s of data.transforms.segments) if (k >= s.output_frames[0] && k <= s.output_frames[1]) return s.name;
    return '';
  }

  function setFrame(k) {
    shown = Math.max(0, Math.min(frameCount - 1, k));
    time = shown / fps;
    if (mixer) mixer.setTime((shown + 0.5) / fps);  // STEP keys: frame k is shown from k/fps on
    dirty = true;
    document.getElementById('frame').value = shown;
    document.getElementById('label').textContent = 'frame ' + shown + ' (' + segmentOf(shown) + ')';
    if (mixer) statusLine.textContent = 'ready: frame ' + shown + ' of ' + frameCount + ', ' + segmentOf(shown);
  }

  function animate(now) {
    requestAnimationFrame(animate);
    if (playing && mixer) {
      const dt = animate.last === undefined ? 0 : (now - animate.last) / 1000;
      time = (time + dt) % (frameCount / fps);
      const k = Math.floor(time * fps);
      if (k !== shown) setFrame(k), time = k / fps + (time * fps - k) / fps;
    }
    animate.last = now;
    if (controls.update()) dirty = true;
    if (dirty) renderer.render(scene, camera), dirty = false;
  }
  controls.addEventListener('change', () => { dirty = true; });

  // Hangs B's nodes of each key segment in a group of their own, so that a clicked pose moves them.
  function groupKeyFrames(root) {
    for (const seg of data.result.segments) {
      const span = data.transforms.segments.find((s) => s.name === 'key ' + seg.index);
      const group = new THREE.Group();
      group.name = 'B at a clicked pose, key segment ' + seg.index;
      root.add(group);
      if (span)
        for (let k = span.output_frames[0]; k <= span.output_frames[1]; ++k)
          if (bNodes[k]) group.add(bNodes[k]);
      poseGroups.push({ index: seg.index, group: group, span: span });
    }
  }

  function onLoad(gltf) {
    const root = gltf.scene;
    scene.add(root);
    root.traverse((node) => {
      const m = /^B frame (\d+) src/.exec(node.name);
      if (m) bNodes[Number(m[1])] = node;
    });
    groupKeyFrames(root);
    mixer = new THREE.AnimationMixer(root);
    const action = mixer.clipAction(gltf.animations[0]);
    action.play();
    frameCamera();
    const wanted = /frame=(\d+)/.exec(window.location.hash);
    setFrame(wanted ? Number(wanted[1]) : 0);
  }

  function bytesOf(base64) {
    const text = atob(base64);
    const bytes = new Uint8Array(text.length);
    for (let i = 0; i < text.length; ++i) bytes[i] = text.charCodeAt(i);
    return bytes.buffer;
  }

  // ---- the solution groups ----
  const columns = { x: 0, y: 1, z: 2, theta: 3, L: 4, thetaA: 5, thetaB: 6, natural: 7 };

  function colourOf(t) {  // blue to red, as the EXR slices
    const ramp = (x) => Math.max(0, Math.min(1, 1.5 - Math.abs(x)));
    return 'rgb(' + [4 * t - 3, 4 * t - 2, 4 * t - 1].map((x) => Math.round(255 * ramp(x))).join(',') + ')';
  }

  // A scatter plot on a canvas: points [u, v, colour], marks [u, v, style]; returns the mapping.
  function scatter(canvas, points, marks, range, labels) {
    const ctx = canvas.getContext('2d');
    const w = canvas.width, h = canvas.height, pad = 34;
    const sx = (u) => pad + (u - range[0]) / (range[1] - range[0] || 1) * (w - pad - 8);
    const sy = (v) => h - pad - (v - range[2]) / (range[3] - range[2] || 1) * (h - pad - 8);
    ctx.clearRect(0, 0, w, h);
    ctx.fillStyle = '#444';
    ctx.font = '11px sans-serif';
    ctx.fillText(labels[0], w / 2 - 20, h - 6);
    ctx.save(); ctx.translate(10, h / 2 + 20); ctx.rotate(-Math.PI / 2); ctx.fillText(labels[1], 0, 0); ctx.restore();
    ctx.fillText(range[0].toFixed(2), pad, h - pad + 12);
    ctx.fillText(range[1].toFixed(2), w - 40, h - pad + 12);
    ctx.fillText(range[2].toFixed(2), 2, h - pad);
    ctx.fillText(range[3].toFixed(2), 2, 16);
    ctx.strokeStyle = '#bbb';
    ctx.strokeRect(pad, 8, w - pad - 8, h - pad - 8);
    for (const p of points) {
      ctx.fillStyle = p[2];
      ctx.fillRect(sx(p[0]) - 1, sy(p[1]) - 1, 3, 3);
    }
    for (const m of marks) {
      ctx.strokeStyle = m[2];
      ctx.lineWidth = 2;
      ctx.beginPath();
      ctx.arc(sx(m[0]), sy(m[1]), 7, 0, 2 * Math.PI);
      ctx.stroke();
    }
    return { sx: sx, sy: sy };
  }

  function extent(rows, a, b) {
    const r = [Infinity, -Infinity, Infinity, -Infinity];
    for (const row of rows) {
      r[0] = Math.min(r[0], row[a]); r[1] = Math.max(r[1], row[a]);
      r[2] = Math.min(r[2], row[b]); r[3] = Math.max(r[3], row[b]);
    }
    return r;
  }

  // The nearest row to a click, in the plot's pixels.
  function nearest(rows, map, a, b, px, py) {
    let best = null, distance = Infinity;
    for (const row of rows) {
      const d = Math.hypot(map.sx(row[a]) - px, map.sy(row[b]) - py);
      if (d < distance) distance = d, best = row;
    }
    return distance < 12 ? best : null;
  }

  function clickAt(canvas, event) {
    const r = canvas.getBoundingClientRect();
    return [(event.clientX - r.left) * canvas.width / r.width, (event.clientY - r.top) * canvas.height / r.height];
  }

  // Shows B at `row` over key segment `seg` (a rigid move of its frames from the chosen pose) and
  // prints the lines that make the DP choose it.
  function showPose(seg, group, row, out) {
    const chosen = seg.chosen, edit = seg.edit;
    const yawA = edit.yaw_a_deg * degrees, turn = (row[columns.theta] - chosen.theta_deg) * degrees;
    const rb = edit.root_b_m, ra = edit.root_a_m;
    const moved = [ra[0] + Math.cos(yawA) * row[columns.x] - Math.sin(yawA) * row[columns.y],
                   ra[1] + Math.sin(yawA) * row[columns.x] + Math.cos(yawA) * row[columns.y]];
    const pivot = gl(rb[0], rb[1], 0), target = gl(moved[0], moved[1], row[columns.z] - chosen.z);
    dirty = true;
    group.group.rotation.set(0, turn, 0);
    group.group.position.copy(target.sub(pivot.clone().applyAxisAngle(new THREE.Vector3(0, 1, 0), turn)));
    if (group.span) setFrame(Math.round((group.span.output_frames[0] + group.span.output_frames[1]) / 2));
    const h = data.groups.find((g) => g.index === seg.index);
    const f = (v) => Number(v.toFixed(4));
    out.textContent =
      'B at x = ' + f(row[columns.x]) + ' m, y = ' + f(row[columns.y]) + ' m, theta = ' + f(row[columns.theta]) + ' deg' +
      ' (L = ' + f(row[columns.L]) + ' m, thetaA = ' + f(row[columns.thetaA]) + ', thetaB = ' + f(row[columns.thetaB]) + ')\n' +
      'To have the DP prefer it, in this key segment of the scene:\n' +
      'prefer = { distance_m = ' + f(row[columns.L]) + ', thetaA_deg = ' + f(row[columns.thetaA]) + ', thetaB_deg = ' + f(row[columns.thetaB]) + ' }\n' +
      'or to leave only the poses around it:\n' +
      'limits = { distance_m = [' + f(row[columns.L] - h.voxel / 2) + ', ' + f(row[columns.L] + h.voxel / 2) + '], thetaA_deg = [' +
      f(row[columns.thetaA] - h.angle_step_deg / 2) + ', ' + f(row[columns.thetaA] + h.angle_step_deg / 2) + '], thetaB_deg = [' +
      f(row[columns.thetaB] - h.angle_step_deg / 2) + ', ' + f(row[columns.thetaB] + h.angle_step_deg / 2) + '] }';
  }

  function segmentSection(seg, group) {
    const section = document.createElement('section');
    const rows = group.rows;
    const scored = rows.length > 0 && rows[0].length > columns.natural;
    const title = document.createElement('h2');
    title.textContent = 'Key segment ' + seg.index + ' (' + seg.type + '): ' + seg.solutions.toLocaleString('en') + ' solutions among ' +
      seg.poses_tested.toLocaleString('en') + ' poses';
    section.appendChild(title);
    const info = document.createElement('div');
    const rejected = Object.entries(seg.rejected).map(([k, v]) => '<tr><td>rejected by ' + k + '</td><td>' + v.toLocaleString('en') + '</td></tr>').join('');
    info.innerHTML = '<table>' + rejected + '</table>' +
      (group.shown < group.members ? '<p>Plotted: every ' + group.stride + 'th of the ' + group.members.toLocaleString('en') + ' members (by rank).</p>' : '') +
      '<p class="legend"><span><span class="swatch" style="background:#000"></span>chosen</span>' +
      (seg.truth ? '<span><span class="swatch" style="background:#1a9a3a"></span>truth (the captured placement)</span>' : '') +
      (scored ? '<span>colour: the natural score, most plausible (blue) to least (red), on a log scale</span></p>'
        : '<span>colour: L, short (blue) to long (red)</span></p>');
    section.appendChild(info);
    // The natural score (docs/method.md section 7b) where the edit wrote it, on log(1 + score); else L.
    const key = scored ? (row) => Math.log1p(row[columns.natural]) : (row) => row[columns.L];
    let low = Infinity, high = -Infinity;
    for (const row of rows) { low = Math.min(low, key(row)); high = Math.max(high, key(row)); }
    const colour = (row) => colourOf((key(row) - low) / ((high - low) || 1));
    const chosen = seg.chosen;
    const descriptors = document.createElement('canvas');
    descriptors.className = 'plot';
    descriptors.width = 420; descriptors.height = 300;
    section.appendChild(descriptors);
    const marks = [[chosen.thetaA_deg, chosen.thetaB_deg, '#000']];
    const map = scatter(descriptors, rows.map((r) => [r[columns.thetaA], r[columns.thetaB], colour(r)]), marks,
      extent(rows.concat([[0, 0, 0, 0, 0, chosen.thetaA_deg, chosen.thetaB_deg]]), columns.thetaA, columns.thetaB), ['thetaA (deg)', 'thetaB (deg)']);
    // (x, y) at one angle.
    const angles = [...new Set(rows.map((r) => r[columns.theta]))].sort((a, b) => a - b);
    const pick = document.createElement('select');
    for (const a of angles) pick.add(new Option('theta = ' + a + ' deg', a));
    pick.value = angles.includes(chosen.theta_deg) ? chosen.theta_deg : angles[0];
    const label = document.createElement('p');
    label.textContent = 'Where B stands relative to A (x, y in A\'s axes, metres) at ';
    label.appendChild(pick);
    section.appendChild(label);
    const positions = document.createElement('canvas');
    positions.className = 'plot';
    positions.width = 420; positions.height = 300;
    section.appendChild(positions);
    const xy = extent(rows.concat(seg.truth ? [[seg.truth.x, seg.truth.y, 0, 0, 0, 0, 0]] : []), columns.x, columns.y);
    let xyMap = null;
    function drawPositions() {
      const theta = Number(pick.value);
      const at = rows.filter((r) => r[columns.theta] === theta);
      const m = [];
      if (chosen.theta_deg === theta) m.push([chosen.x, chosen.y, '#000']);
      if (seg.truth && seg.truth.theta_deg === theta) m.push([seg.truth.x, seg.truth.y, '#1a9a3a']);
      xyMap = scatter(positions, at.map((r) => [r[columns.x], r[columns.y], colour(r)]), m, xy, ['x (m)', 'y (m)']);
      return at;
    }
    let atAngle = drawPositions();
    pick.addEventListener('change', () => { atAngle = drawPositions(); });
    const out = document.createElement('pre');
    out.textContent = 'Click a solution to see B there.';
    section.appendChild(out);
    const poseGroup = poseGroups.find((g) => g.index === seg.index);
    descriptors.addEventListener('click', (e) => {
      const [px, py] = clickAt(descriptors, e);
      const row = nearest(rows, map, columns.thetaA, columns.thetaB, px, py);
      if (row) pick.value = row[columns.theta], atAngle = drawPositions(), showPose(seg, poseGroup, row, out);
    });
    positions.addEventListener('click', (e) => {
      const [px, py] = clickAt(positions, e);
      const row = nearest(atAngle, xyMap, columns.x, columns.y, px, py);
      if (row) showPose(seg, poseGroup, row, out);
    });
    section.pick = (row) => { pick.value = row[columns.theta]; atAngle = drawPositions(); showPose(seg, poseGroup, row, out); };
    const back = document.createElement('button');
    back.textContent = 'Back to the chosen pose';
    back.addEventListener('click', () => { poseGroup.group.position.set(0, 0, 0); poseGroup.group.rotation.set(0, 0, 0); out.textContent = ''; dirty = true; });
    section.appendChild(back);
    if (group.montage) {
      const img = document.createElement('img');
      img.className = 'montage';
      img.src = group.montage;
      img.alt = 'feasibility maps per angle';
      section.appendChild(img);
    }
    return section;
  }

  function summary() {
    const r = data.result;
    const lines = [r.segments.length + ' key segment(s), ' + frameCount + ' output frames at ' + fps + ' fps'];
    if (r.dp) lines.push('DP cost ' + r.dp.cost.toFixed(4) + (r.dp.choices_tried > 1 ? ', after ' + r.dp.choices_tried + ' choices' : ''));
    if (r.transitions) lines.push('transitional frames overlapping: ' + r.transitions.reduce((n, t) => n + t.frames_overlapping, 0));
    document.getElementById('summary').textContent = lines.join('; ');
  }

  // ---- start ----
  try {
    resize();
    const timeline = document.getElementById('timeline');
    for (const s of data.transforms.segments) {
      if (!s.name.startsWith('key')) continue;
      const mark = document.createElement('span');
      mark.style.left = (100 * s.output_frames[0] / frameCount) + '%';
      mark.style.width = (100 * (s.output_frames[1] - s.output_frames[0] + 1) / frameCount) + '%';
      mark.title = s.name;
      timeline.appendChild(mark);
    }
    const slider = document.getElementById('frame');
    slider.max = frameCount - 1;
    slider.addEventListener('input', () => setFrame(Number(slider.value)));
    document.getElementById('play').addEventListener('click', (e) => {
      playing = !playing;
      e.target.textContent = playing ? 'Pause' : 'Play';
    });
    new THREE.GLTFLoader().parse(bytesOf(window.AMHV_GLB), '', (gltf) => {
      onLoad(gltf);
      summary();
      const list = document.getElementById('segments');
      for (const seg of data.result.segments) {
        const group = data.groups.find((g) => g.index === seg.index);
        if (!group || !group.rows.length) continue;
        const section = segmentSection(seg, group);
        list.appendChild(section);
        const picked = /pick=(\d+),(\d+)/.exec(window.location.hash);
        if (picked && Number(picked[1]) === seg.index && group.rows[Number(picked[2])]) section.pick(group.rows[Number(picked[2])]);
      }
    }, (e) => fail('scene.glb: ' + (e && e.message ? e.message : e)));
    requestAnimationFrame(animate);
  } catch (e) {
    fail(e.message || String(e));
  }
})();
