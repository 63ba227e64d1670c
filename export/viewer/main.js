// The 3D view of `abrad report`: a bake's glTF (the exporter's baked vertex colours,
// KHR_materials_unlit) drawn by three.js with orbit controls. esbuild bundles this file with
// three.js into one classic script (build_viewer.sh), since a page opened from file:// may not
// load ES modules or fetch files; the page hands the model over as base64 text instead.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

// Decodes base64 text into an ArrayBuffer
function decodeBase64(text) {
    const binary = atob(text);
    const bytes = new Uint8Array(binary.length);
    for (let i = 0; i < binary.length; ++i) bytes[i] = binary.charCodeAt(i);
    return bytes.buffer;
}

// Shows the model in `canvas`. options: { model: base64 GLB, camera: { eye, target,
// fovDeg } in the glTF frame (Y up, metres, the root node's translation included) or null to
// frame the whole model }. Returns a promise of { triangles, camera(), overview() }: the
// model's triangle count and two functions that move the view to the camera or to a view of
// the whole model.
function show(canvas, options) {
    const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setClearColor(0x202020, 1);
    const scene = new THREE.Scene();
    const camera = new THREE.PerspectiveCamera(60, 1, 0.01, 1000);
    const controls = new OrbitControls(camera, canvas);
    controls.enableDamping = false;

    // Match the drawing buffer to the canvas's size on the page
    function resize() {
        const w = Math.max(1, canvas.clientWidth);
        const h = Math.max(1, canvas.clientHeight);
        renderer.setSize(w, h, false);
        camera.aspect = w / h;
        camera.updateProjectionMatrix();
    }
    function draw() {
        renderer.render(scene, camera);
    }
    return new Promise((resolve, reject) => {
        new GLTFLoader().parse(decodeBase64(options.model), '', (gltf) => {
            scene.add(gltf.scene);
            // Frame the model: its bounding box sets the clipping planes
            const box = new THREE.Box3().setFromObject(gltf.scene);
            const size = box.getSize(new THREE.Vector3()).length() || 1;
            const centre = box.getCenter(new THREE.Vector3());
            // Two places to look from: the bake's camera (when given) and the whole model
            // from above one corner
            const overview = () => {
                camera.fov = 50;
                camera.position.copy(centre).add(new THREE.Vector3(0.6, 0.5, 0.8).multiplyScalar(size));
                controls.target.copy(centre);
            };
            const atCamera = () => {
                const view = options.camera;
                if (!view) return overview();
                camera.fov = view.fovDeg;
                camera.position.fromArray(view.eye);
                controls.target.fromArray(view.target);
            };
            camera.near = size / 2000;
            camera.far = size * 10;
            const lookFrom = (place) => {
                place();
                resize();
                controls.update();
                draw();
            };
            atCamera();
            resize();
            controls.update();
            let triangles = 0;
            gltf.scene.traverse((o) => {
                if (o.isMesh) triangles += (o.geometry.index ? o.geometry.index.count : o.geometry.attributes.position.count) / 3;
            });
            controls.addEventListener('change', draw);
            window.addEventListener('resize', () => { resize(); draw(); });
            draw();
            resolve({ triangles, camera: () => lookFrom(atCamera), overview: () => lookFrom(overview) });
        }, reject);
    });
}

window.abradViewer = { show, threeRevision: THREE.REVISION };
