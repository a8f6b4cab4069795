// Runs a wasm32-wasi command module under node's WASI: node wasi_run.mjs prog.wasm [args...]
// The whole host file system is visible at / (the golden runner reads harness/scenes), the exit
// status is the program's. Needs node >= 18 (node:wasi, preview1).
import { readFile } from 'node:fs/promises';
import { WASI } from 'node:wasi';
import process from 'node:process';

const [program, ...args] = process.argv.slice(2);
if (!program) {
    process.stderr.write('usage: node wasi_run.mjs program.wasm [args...]\n');
    process.exit(2);
}
const wasi = new WASI({ version: 'preview1', args: [program, ...args], env: {}, preopens: { '/': '/' }, returnOnExit: true });
const module = await WebAssembly.compile(await readFile(program));
const instance = await WebAssembly.instantiate(module, wasi.getImportObject());
process.exitCode = wasi.start(instance);
