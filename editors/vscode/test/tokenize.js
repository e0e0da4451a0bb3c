#!/usr/bin/env node
// Tokenizes .servo text with the engine VS Code uses (vscode-textmate on
// vscode-oniguruma) and the extension's grammar.
//
//   node test/tokenize.js FILE.servo...   print each line's tokens and scopes
//   node test/tokenize.js                 read {"text": "..."} as JSON on standard
//                                         input, write [[{text, scopes}, ...], ...]
//                                         (one list of tokens per line) as JSON
//
// Lines are tokenized in order, each starting from the state the previous one
// ended in, as in the editor. Needs `npm install` in editors/vscode.
'use strict';

const fs = require('fs');
const path = require('path');
const vsctm = require('vscode-textmate');
const oniguruma = require('vscode-oniguruma');

const GRAMMAR = path.join(__dirname, '..', 'syntaxes', 'servo.tmLanguage.json');

async function loadGrammar() {
  const wasm = fs.readFileSync(require.resolve('vscode-oniguruma/release/onig.wasm'));
  await oniguruma.loadWASM(wasm.buffer.slice(wasm.byteOffset, wasm.byteOffset + wasm.byteLength));
  const registry = new vsctm.Registry({
    onigLib: Promise.resolve({
      createOnigScanner: (patterns) => new oniguruma.OnigScanner(patterns),
      createOnigString: (s) => new oniguruma.OnigString(s),
    }),
    loadGrammar: async (scopeName) => {
      if (scopeName !== 'source.servo') return null;
      return vsctm.parseRawGrammar(fs.readFileSync(GRAMMAR, 'utf8'), GRAMMAR);
    },
  });
  const grammar = await registry.loadGrammar('source.servo');
  if (!grammar) throw new Error(`cannot load ${GRAMMAR}`);
  return grammar;
}

function tokenize(grammar, text) {
  let state = vsctm.INITIAL;
  return text.split(/\r?\n/).map((line) => {
    const result = grammar.tokenizeLine(line, state);
    state = result.ruleStack;
    return result.tokens
      .map((t) => ({ text: line.slice(t.startIndex, t.endIndex), scopes: t.scopes }))
      .filter((t) => t.text.length > 0);
  });
}

function readStdin() {
  return new Promise((resolve, reject) => {
    const chunks = [];
    process.stdin.on('data', (c) => chunks.push(c));
    process.stdin.on('end', () => resolve(Buffer.concat(chunks).toString('utf8')));
    process.stdin.on('error', reject);
  });
}

async function main() {
  const grammar = await loadGrammar();
  const files = process.argv.slice(2);
  if (files.length === 0) {
    const request = JSON.parse(await readStdin());
    process.stdout.write(JSON.stringify(tokenize(grammar, request.text)) + '\n');
    return;
  }
  for (const file of files) {
    tokenize(grammar, fs.readFileSync(file, 'utf8')).forEach((tokens, i) => {
      for (const t of tokens) {
        if (t.text.trim()) console.log(`${file}:${i + 1}: ${JSON.stringify(t.text)} ${t.scopes.slice(1).join(' ')}`);
      }
    });
  }
}

main().catch((err) => {
  console.error(err && err.stack ? err.stack : String(err));
  process.exit(1);
});
