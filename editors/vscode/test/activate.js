#!/usr/bin/env node
// Activates extension.js outside VS Code, against a stand-in for the `vscode`
// API and for vscode-languageclient's LanguageClient, and prints as JSON what
// it did: the server it started, the commands and task providers it
// registered, the tasks it provides.
//
//   node test/activate.js [SERVOC_PATH]    SERVOC_PATH: the servoc.path setting
'use strict';

const Module = require('module');
const path = require('path');

const setting = process.argv[2];
const record = { clients: [], commands: [], taskProviders: [], tasks: [], errors: [] };

class Task {
  constructor(definition, scope, name, source, execution, problemMatchers) {
    Object.assign(this, { definition, scope, name, source, execution, problemMatchers });
  }
}
class ProcessExecution {
  constructor(process, args) {
    Object.assign(this, { process, args });
  }
}
const disposable = () => ({ dispose() {} });

const vscode = {
  Task,
  ProcessExecution,
  TaskScope: { Global: 1, Workspace: 2 },
  TaskGroup: { Build: { id: 'build' } },
  window: {
    createOutputChannel: (name) => ({ name, dispose() {}, appendLine() {} }),
    showErrorMessage: async (message) => {
      record.errors.push(message);
      return undefined;
    },
  },
  workspace: {
    workspaceFolders: [{ uri: { fsPath: '/ws' } }],
    getConfiguration: (section) => ({
      get: (key, fallback) => (section === 'servoc' && key === 'path' && setting !== undefined ? setting : fallback),
    }),
    onDidChangeConfiguration: () => disposable(),
  },
  commands: {
    registerCommand: (id) => {
      record.commands.push(id);
      return disposable();
    },
    executeCommand: async () => undefined,
  },
  tasks: {
    registerTaskProvider: (type, provider) => {
      record.taskProviders.push(type);
      for (const task of provider.provideTasks()) {
        record.tasks.push({
          name: task.name,
          definition: task.definition,
          process: task.execution.process,
          args: task.execution.args,
          problemMatchers: task.problemMatchers,
        });
      }
      const resolved = provider.resolveTask(
        new Task({ type: 'servoc', command: 'compile', file: 'a.servo', args: ['-o', 'a.hex'] }, 2, 'mine'),
      );
      record.resolved = { name: resolved.name, args: resolved.execution.args, problemMatchers: resolved.problemMatchers };
      return disposable();
    },
  },
};

class LanguageClient {
  constructor(id, name, serverOptions, clientOptions) {
    record.clients.push({ id, name, serverOptions, documentSelector: clientOptions.documentSelector });
  }
  async start() {}
  async stop() {}
  async dispose() {}
}
const languageclient = { LanguageClient, TransportKind: { stdio: 0, ipc: 1, pipe: 2, socket: 3 } };

const stubs = { vscode, 'vscode-languageclient/node': languageclient };
const resolve = Module._resolveFilename;
Module._resolveFilename = function (request, ...rest) {
  return request in stubs ? `stub:${request}` : resolve.call(this, request, ...rest);
};
for (const [name, exports] of Object.entries(stubs)) {
  require.cache[`stub:${name}`] = { id: name, filename: name, loaded: true, exports };
}

const extension = require(path.join(__dirname, '..', 'extension.js'));
const subscriptions = [];
extension
  .activate({ subscriptions })
  .then(() => extension.deactivate())
  .then(() => {
    record.exports = Object.keys(extension).sort();
    process.stdout.write(JSON.stringify(record, null, 2) + '\n');
  })
  .catch((err) => {
    console.error(err && err.stack ? err.stack : String(err));
    process.exit(1);
  });
