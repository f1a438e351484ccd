// node render.js MODULES PAGE_DIR CHROMIUM JOB.json OUT.bin
// Serves page.html (and three.js from MODULES) on a local port, opens it in headless Chromium
// with software WebGL, renders the job's views and writes their float32 RGBA pixels, bottom row
// first, one view after another.
const http = require('http');
const fs = require('fs');
const path = require('path');

const [modules, pageDir, chromium, jobPath, outPath] = process.argv.slice(2);
const puppeteer = require(path.join(modules, 'puppeteer-core'));
const TYPES = { '.js': 'text/javascript', '.html': 'text/html', '.wasm': 'application/wasm' };

const server = http.createServer((request, response) => {
  const url = decodeURIComponent(request.url.split('?')[0]);
  const file = url.startsWith('/three/') ? path.join(modules, url) : path.join(pageDir, path.basename(url));
  fs.readFile(file, (error, data) => {
    if (error) { response.writeHead(404); response.end(); return; }
    response.writeHead(200, { 'Content-Type': TYPES[path.extname(file)] || 'application/octet-stream' });
    response.end(data);
  });
});

server.listen(0, '127.0.0.1', async () => {
  let browser;
  try {
    browser = await puppeteer.launch({ executablePath: chromium, headless: true,
      args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'] });
    const page = await browser.newPage();
    const errors = [];
    page.on('pageerror', (error) => errors.push(error.message));
    await page.goto(`http://127.0.0.1:${server.address().port}/page.html`);
    await page.waitForFunction('window.ready === true', { timeout: 60000 });
    const job = JSON.parse(fs.readFileSync(jobPath, 'utf8'));
    const glb = fs.readFileSync(job.model).toString('base64');
    const pictures = await page.evaluate((g, v, s, n, d) => window.renderViews(g, v, s, n, d),
                                         glb, job.views, job.size, job.samples, Boolean(job.shadows));
    if (errors.length) throw new Error(errors.join('; '));
    fs.writeFileSync(outPath, Buffer.concat(pictures.map((b) => Buffer.from(b, 'base64'))));
  } catch (error) {
    console.error(String(error));
    process.exitCode = 1;
  } finally {
    if (browser) await browser.close();
    server.close();
  }
});
