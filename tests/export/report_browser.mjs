// Opens an `abrad report` page from file:// in Debian's chromium (headless, WebGL through
// SwiftShader) with puppeteer-core and checks what a person would see: no console error, no
// failed request, the 3D view drawn (a screenshot of its canvas with pixels other than the
// background), the isolux plans drawn, and the grid statistics on the page equal to those of
// the grid CSV files the bake wrote (read independently here).
//
//   node report_browser.mjs --modules NODE_MODULES_DIR --chromium PATH --page DIR/index.html
//        --shot SHOT.png --luminaires N [--grid NAME=CSV]...
// Exit status 0 when every check passes, 1 otherwise (each failure printed).

import { readFileSync, writeFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const args = { grid: [] };
for (let k = 2; k < process.argv.length; k += 2) {
    const key = process.argv[k].replace(/^--/, '');
    const value = process.argv[k + 1];
    if (key === 'grid') args.grid.push(value);
    else args[key] = value;
}
// puppeteer-core from the test set-up's node_modules (tests/export/npm_install.sh)
const puppeteer = createRequire(path.join(path.resolve(args.modules), 'index.js'))('puppeteer-core');
const failures = [];
const check = (ok, message) => {
    if (!ok) failures.push(message);
};

// The statistics of a grid CSV (x,y,z,illuminance,...): mean, min and max of the fourth column
function csvStatistics(path) {
    const lines = readFileSync(path, 'utf8').trim().split('\n').slice(1);
    const values = lines.map((l) => Number(l.split(',')[3]));
    const sum = values.reduce((a, b) => a + b, 0);
    const avg = sum / values.length;
    const min = Math.min(...values);
    return { points: values.length, e_avg: avg, e_min: min, e_max: Math.max(...values), u0: avg > 0 ? min / avg : 0 };
}

const near = (a, b, rel) => Math.abs(a - b) <= rel * Math.max(Math.abs(a), Math.abs(b), 1e-12);

const browser = await puppeteer.launch({
    executablePath: args.chromium,
    headless: true,
    // WebGL without a GPU: ANGLE on SwiftShader (Debian's chromium ships it)
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
           '--window-size=1280,2000'],
});
try {
    const page = await browser.newPage();
    await page.setViewport({ width: 1280, height: 2000 });
    page.on('console', (m) => {
        if (m.type() === 'error') failures.push(`console error: ${m.text()}`);
    });
    page.on('pageerror', (e) => failures.push(`page error: ${e.message}`));
    page.on('requestfailed', (r) => failures.push(`request failed: ${r.url()} (${r.failure()?.errorText})`));
    await page.goto(pathToFileURL(args.page).href, { waitUntil: 'load' });

    // The 3D view: wait until the viewer says it drew (or failed)
    await page.waitForFunction(() => document.body.dataset.viewer !== 'loading', { timeout: 120000 });
    const viewer = await page.evaluate(() => document.body.dataset.viewer);
    check(viewer === 'ready', `the 3D view is '${viewer}', not 'ready'`);
    if (viewer === 'ready') {
        const canvas = await page.$('#abrad-3d');
        const shot = await canvas.screenshot({ encoding: 'base64' });
        writeFileSync(args.shot, Buffer.from(shot, 'base64'));
        // Decode the screenshot in the page and count the pixels that are not the background
        const counts = await page.evaluate(async (data) => {
            const img = new Image();
            img.src = 'data:image/png;base64,' + data;
            await img.decode();
            const c = document.createElement('canvas');
            c.width = img.width;
            c.height = img.height;
            const g = c.getContext('2d');
            g.drawImage(img, 0, 0);
            const px = g.getImageData(0, 0, c.width, c.height).data;
            let other = 0;
            const colours = new Set();
            for (let i = 0; i < px.length; i += 4) {
                const d = Math.abs(px[i] - 0x20) + Math.abs(px[i + 1] - 0x20) + Math.abs(px[i + 2] - 0x20);
                if (d > 12) other += 1;
                colours.add((px[i] >> 3) << 10 | (px[i + 1] >> 3) << 5 | (px[i + 2] >> 3));
            }
            return { total: px.length / 4, other, colours: colours.size };
        }, shot);
        console.log(`3D view: ${counts.other} of ${counts.total} pixels drawn, ${counts.colours} colours`);
        check(counts.other > 0.2 * counts.total, `the 3D view is nearly blank: ${counts.other} of ${counts.total} pixels drawn`);
        check(counts.colours > 20, `the 3D view has only ${counts.colours} colours (no shading)`);
    }

    // Grid statistics against the bake's CSV files
    const page_grids = await page.evaluate(() => [...document.querySelectorAll('tr[data-grid]')].map((tr) => {
        const field = (f) => {
            const td = tr.querySelector(`td[data-field="${f}"]`);
            return td ? { exact: Number(td.dataset.value), shown: Number(td.textContent) } : null;
        };
        return { name: tr.dataset.grid, points: tr.querySelector('td[data-field="points"]').textContent,
                 e_avg: field('e_avg'), e_min: field('e_min'), e_max: field('e_max'), u0: field('u0') };
    }));
    check(page_grids.length === args.grid.length, `${page_grids.length} grids on the page, ${args.grid.length} expected`);
    for (const spec of args.grid) {
        const [name, csv] = spec.split('=');
        const want = csvStatistics(csv);
        const got = page_grids.find((g) => g.name === name);
        if (!got) {
            failures.push(`grid '${name}' is not on the page`);
            continue;
        }
        const [nx, ny] = got.points.split('×').map((s) => Number(s.trim()));
        check(nx * ny === want.points, `grid '${name}': ${got.points} points, the CSV has ${want.points}`);
        for (const key of ['e_avg', 'e_min', 'e_max', 'u0']) {
            // data-value holds the double; the CSV's 9 significant digits bound the difference
            check(near(got[key].exact, want[key], 1e-7), `grid '${name}' ${key}: page ${got[key].exact}, CSV ${want[key]}`);
            // the text shows four significant digits (U0 three decimals)
            const tolerance = key === 'u0' ? 0.0005 + 1e-9 : 0.0005 * Math.abs(want[key]) + 1e-9;
            check(Math.abs(got[key].shown - want[key]) <= tolerance, `grid '${name}' ${key}: page shows ${got[key].shown}, CSV ${want[key]}`);
        }
        console.log(`grid '${name}': E_avg ${got.e_avg.shown}, E_min ${got.e_min.shown}, E_max ${got.e_max.shown}, U0 ${got.u0.shown} (CSV ${want.e_avg.toFixed(3)}, ${want.e_min.toFixed(3)}, ${want.e_max.toFixed(3)}, ${want.u0.toFixed(4)})`);
    }
    // Every grid's plan has its cells image loaded and isolux contours
    const plans = await page.evaluate(() => [...document.querySelectorAll('svg.plan')].map((svg) => ({
        contours: svg.querySelectorAll('g.contour path').length,
        image: svg.querySelector('image').getAttribute('href'),
    })));
    check(plans.length === args.grid.length, `${plans.length} plans, ${args.grid.length} expected`);
    for (const p of plans) check(p.contours > 0, `plan ${p.image} has no isolux contour`);

    // The luminaire schedule counts every luminaire
    const counted = await page.evaluate(() => [...document.querySelectorAll('#luminaire-table td[data-field="count"]')]
        .reduce((n, td) => n + Number(td.textContent), 0));
    check(counted === Number(args.luminaires), `the schedule counts ${counted} luminaires, ${args.luminaires} expected`);
} finally {
    await browser.close();
}
for (const f of failures) console.error(`report_browser: ${f}`);
if (failures.length === 0) console.log('report_browser: every check passed');
process.exit(failures.length === 0 ? 0 : 1);
