// The 3D view: the MuJoCo model's geoms (sent once by the simulator) grouped per body, moved
// by the body poses of each state message; the tool's recent path as a line; the overhead
// camera's field of view as a frustum down to the table. Frame B of the model: z up, metres.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

THREE.Object3D.DEFAULT_UP.set(0, 0, 1);

const COLOR_INDEX = { red: 0, green: 1, blue: 2 };

function quat(q) {
  return new THREE.Quaternion(q[1], q[2], q[3], q[0]);  // MuJoCo (w, x, y, z)
}

function geometryFor(g) {
  const [a, b, c] = g.size;
  switch (g.type) {
    case 'box':
      return new THREE.BoxGeometry(2 * a, 2 * b, 2 * c);
    case 'sphere':
      return new THREE.SphereGeometry(a, 24, 16);
    case 'cylinder':
      return new THREE.CylinderGeometry(a, a, 2 * b, 32).rotateX(Math.PI / 2);
    case 'capsule':
      return new THREE.CapsuleGeometry(a, 2 * b, 8, 24).rotateX(Math.PI / 2);
    case 'plane':
      return new THREE.PlaneGeometry(a > 0 ? 2 * a : 2, b > 0 ? 2 * b : 2);
    default:
      return null;
  }
}

export class View3D {
  constructor(container) {
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, alpha: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.shadowMap.enabled = true;
    this.renderer.shadowMap.type = THREE.PCFShadowMap;
    container.prepend(this.renderer.domElement);

    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.005, 20);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = true;
    this.controls.dampingFactor = 0.12;
    this.controls.screenSpacePanning = true;
    this.controls.minDistance = 0.08;
    this.controls.maxDistance = 3;

    this.scene.add(new THREE.HemisphereLight(0xdfe8ff, 0x20242c, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 2.2);
    sun.position.set(0.5, -0.6, 1.2);
    sun.castShadow = true;
    sun.shadow.mapSize.set(1024, 1024);
    const sc = sun.shadow.camera;
    sc.left = -0.45; sc.right = 0.45; sc.top = 0.45; sc.bottom = -0.45; sc.near = 0.2; sc.far = 3;
    sun.shadow.bias = -0.0005;
    this.scene.add(sun);
    this.sun = sun;

    this.root = new THREE.Group();
    this.scene.add(this.root);
    this.bodies = [];
    this.cubeBodies = new Map();  // cube id -> body index
    this.pathLine = null;
    this.fov = null;
    this.target = new THREE.Vector3(0.1, 0, -0.02);
    this.setView('iso');

    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
    const loop = () => {
      this.controls.update();
      this.renderer.render(this.scene, this.camera);
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  resize() {
    const w = this.container.clientWidth;
    const h = this.container.clientHeight;
    if (w === 0 || h === 0) return;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
  }

  setView(name) {
    const t = this.target;
    if (name === 'top') {
      this.camera.position.set(t.x, t.y - 0.001, t.z + 0.75);
    } else if (name === 'camera' && this.sceneMsg) {
      const c = this.sceneMsg.camera;
      this.camera.position.set(c.pos[0], c.pos[1], c.pos[2]);
      this.controls.target.set(c.look_at[0], c.look_at[1], c.look_at[2]);
      this.camera.fov = c.fovy_deg;
      this.camera.updateProjectionMatrix();
      return;
    } else {
      this.camera.position.set(t.x + 0.5, t.y - 0.62, t.z + 0.5);
    }
    this.camera.fov = 40;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(t);
  }

  // Builds the scene from the "scene" message (again after a reconnect: the model may differ).
  build(msg) {
    this.sceneMsg = msg;
    this.scene.remove(this.root);
    this.root = new THREE.Group();
    this.scene.add(this.root);
    this.bodies = msg.bodies.map((name) => {
      const g = new THREE.Group();
      g.name = name;
      this.root.add(g);
      return g;
    });
    // cubes: body "cube_<colour>_<index>", id = colour * pool + index
    const pool = msg.bodies.filter((n) => n.startsWith('cube_red_')).length;
    this.cubeBodies.clear();
    msg.bodies.forEach((name, i) => {
      const m = /^cube_(red|green|blue)_(\d+)$/.exec(name);
      if (m) {
        this.cubeBodies.set(COLOR_INDEX[m[1]] * pool + Number(m[2]), i);
        this.bodies[i].visible = false;
        this.bodies[i].userData.cubeColor = m[1];
      }
    });
    for (const g of msg.geoms) {
      if (g.rgba[3] <= 0.01) continue;
      const geo = geometryFor(g);
      if (!geo) continue;
      const color = new THREE.Color().setRGB(g.rgba[0], g.rgba[1], g.rgba[2], THREE.SRGBColorSpace);
      const isCube = this.bodies[g.body].userData.cubeColor !== undefined;
      const mat = new THREE.MeshStandardMaterial({
        color,
        roughness: g.type === 'plane' ? 0.95 : 0.55,
        metalness: isCube ? 0.0 : 0.15,
        transparent: g.rgba[3] < 0.99,
        opacity: g.rgba[3],
      });
      const mesh = new THREE.Mesh(geo, mat);
      mesh.position.set(g.pos[0], g.pos[1], g.pos[2]);
      mesh.quaternion.copy(quat(g.quat));
      mesh.castShadow = g.type !== 'plane' && g.body !== 0;
      mesh.receiveShadow = true;
      if (isCube) {
        const edges = new THREE.LineSegments(new THREE.EdgesGeometry(geo),
          new THREE.LineBasicMaterial({ color: 0x000000, transparent: true, opacity: 0.35 }));
        mesh.add(edges);
      }
      this.bodies[g.body].add(mesh);
    }
    this.addTableGrid(msg);
    this.addPath();
    this.addFieldOfView(msg.camera, msg.table_z);
    this.target.set(0.1, 0, msg.table_z + 0.02);
  }

  addTableGrid(msg) {
    const grid = new THREE.GridHelper(0.6, 12, 0x5a6b85, 0x3a4659);
    grid.rotateX(Math.PI / 2);
    grid.position.set(0.08, 0, msg.table_z + 0.0005);
    grid.material.transparent = true;
    grid.material.opacity = 0.35;
    this.root.add(grid);
    const axes = new THREE.AxesHelper(0.05);
    axes.position.set(0, 0, msg.table_z + 0.001);
    this.root.add(axes);
  }

  addPath() {
    const geo = new THREE.BufferGeometry();
    geo.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * 2000), 3));
    geo.setAttribute('color', new THREE.BufferAttribute(new Float32Array(3 * 2000), 3));
    geo.setDrawRange(0, 0);
    this.pathLine = new THREE.Line(geo, new THREE.LineBasicMaterial({ vertexColors: true, transparent: true, opacity: 0.95 }));
    this.pathLine.frustumCulled = false;
    this.root.add(this.pathLine);
  }

  addFieldOfView(cam, tableZ) {
    const p = new THREE.Vector3(...cam.pos);
    const ax = new THREE.Vector3(...cam.x);
    const ay = new THREE.Vector3(...cam.y);
    const az = new THREE.Vector3(...cam.z);
    const ty = Math.tan((cam.fovy_deg * Math.PI) / 360);
    const tx = ty * (cam.width_px / cam.height_px);
    const corners = [[-1, -1], [1, -1], [1, 1], [-1, 1]].map(([u, v]) => {
      const d = az.clone().negate().addScaledVector(ax, u * tx).addScaledVector(ay, v * ty);
      const t = (tableZ - p.z) / d.z;
      return p.clone().addScaledVector(d, t > 0 ? t : 0.3);
    });
    const group = new THREE.Group();
    const pts = [];
    for (const c of corners) pts.push(p, c);
    for (let i = 0; i < 4; i++) pts.push(corners[i], corners[(i + 1) % 4]);
    const lines = new THREE.LineSegments(new THREE.BufferGeometry().setFromPoints(pts),
      new THREE.LineBasicMaterial({ color: 0x4fb3ff, transparent: true, opacity: 0.55 }));
    group.add(lines);
    const lift = 0.0012;
    const footprint = new THREE.BufferGeometry().setFromPoints(corners.map((c) => c.clone().setZ(tableZ + lift)));
    footprint.setIndex([0, 1, 2, 0, 2, 3]);
    group.add(new THREE.Mesh(footprint, new THREE.MeshBasicMaterial({
      color: 0x4fb3ff, transparent: true, opacity: 0.07, side: THREE.DoubleSide, depthWrite: false })));
    // the camera itself: a small dark box looking along -z of its frame
    const body = new THREE.Mesh(new THREE.BoxGeometry(0.05, 0.035, 0.03),
      new THREE.MeshStandardMaterial({ color: 0x2b3240, roughness: 0.5, metalness: 0.4 }));
    body.position.copy(p).addScaledVector(az, 0.02);
    body.quaternion.setFromRotationMatrix(new THREE.Matrix4().makeBasis(ax, ay, az));
    const lens = new THREE.Mesh(new THREE.CylinderGeometry(0.01, 0.012, 0.012, 20).rotateX(Math.PI / 2),
      new THREE.MeshStandardMaterial({ color: 0x4fb3ff, emissive: 0x12314a, roughness: 0.2 }));
    lens.position.set(0, 0, -0.02);
    body.add(lens);
    group.add(body);
    this.fov = group;
    this.root.add(group);
  }

  update(state) {
    const bodies = state.bodies;
    for (let i = 1; i < bodies.length && i < this.bodies.length; i++) {
      const b = bodies[i];
      this.bodies[i].position.set(b[0], b[1], b[2]);
      this.bodies[i].quaternion.set(b[4], b[5], b[6], b[3]);
    }
    const active = new Set(state.cubes.map((c) => c.id));
    for (const [id, index] of this.cubeBodies) this.bodies[index].visible = active.has(id);
    if (state.path && this.pathLine) this.setPath(state.path);
  }

  setPath(flat) {
    const geo = this.pathLine.geometry;
    const pos = geo.attributes.position;
    const col = geo.attributes.color;
    const n = Math.min(flat.length / 3, pos.count);
    const start = flat.length / 3 - n;
    const c0 = new THREE.Color(0x1d2a3a);
    const c1 = new THREE.Color(0xffb347);
    const c = new THREE.Color();
    for (let i = 0; i < n; i++) {
      const k = 3 * (start + i);
      pos.setXYZ(i, flat[k], flat[k + 1], flat[k + 2]);
      c.copy(c0).lerp(c1, n > 1 ? i / (n - 1) : 1);
      col.setXYZ(i, c.r, c.g, c.b);
    }
    pos.needsUpdate = true;
    col.needsUpdate = true;
    geo.setDrawRange(0, n);
  }

  showPath(on) { if (this.pathLine) this.pathLine.visible = on; }
  showFieldOfView(on) { if (this.fov) this.fov.visible = on; }

  // For tests and debugging: the cubes drawn in the scene, with their colour and position.
  visibleCubes() {
    const out = [];
    for (const [id, index] of this.cubeBodies) {
      const b = this.bodies[index];
      if (!b.visible) continue;
      const mesh = b.children.find((m) => m.isMesh);
      out.push({
        id,
        color: b.userData.cubeColor,
        rgb: mesh ? mesh.material.color.getHexString() : null,
        pos: [b.position.x, b.position.y, b.position.z],
      });
    }
    return out;
  }
}
