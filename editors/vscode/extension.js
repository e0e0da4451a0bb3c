// The servoc extension: starts the servoc language server (`servoc lsp`) for
// .servo files and provides `servoc` tasks whose output the `$servoc` problem
// matcher reads. Plain JavaScript: no build step.
'use strict';

const os = require('os');
const path = require('path');
const vscode = require('vscode');
const { LanguageClient, TransportKind } = require('vscode-languageclient/node');

const TASK_TYPE = 'servoc';
const SELECTOR = [
  { scheme: 'file', language: 'servo' },
  { scheme: 'untitled', language: 'servo' },
];

/** @type {LanguageClient | undefined} */
let client;
/** @type {vscode.OutputChannel | undefined} */
let output;

/** The `servoc.path` setting with `~` and `${workspaceFolder}` expanded. */
function servocCommand() {
  let command = vscode.workspace.getConfiguration('servoc').get('path', 'servoc') || 'servoc';
  const folder = vscode.workspace.workspaceFolders && vscode.workspace.workspaceFolders[0];
  if (folder) command = command.replace(/\$\{workspaceFolder\}/g, folder.uri.fsPath);
  if (command === '~' || command.startsWith('~/')) command = path.join(os.homedir(), command.slice(1));
  return command;
}

async function startClient() {
  const command = servocCommand();
  const serverOptions = {
    run: { command, args: ['lsp'], transport: TransportKind.stdio },
    debug: { command, args: ['lsp'], transport: TransportKind.stdio },
  };
  const clientOptions = {
    documentSelector: SELECTOR,
    outputChannel: output,
  };
  client = new LanguageClient('servoc', 'servoc', serverOptions, clientOptions);
  try {
    await client.start();
  } catch (err) {
    const failed = client;
    client = undefined;
    try {
      await failed.dispose();
    } catch (_) {
      // the server never started: nothing to stop
    }
    const message = err && err.message ? err.message : String(err);
    const choice = await vscode.window.showErrorMessage(
      `servoc: cannot start the language server \`${command} lsp\` (${message}). ` +
        "Install it with `pip install 'servoc[lsp]'`, or set `servoc.path` to the servoc command.",
      'Open Settings',
    );
    if (choice === 'Open Settings') {
      await vscode.commands.executeCommand('workbench.action.openSettings', 'servoc.path');
    }
  }
}

async function stopClient() {
  if (!client) return;
  const running = client;
  client = undefined;
  try {
    await running.stop();
  } catch (_) {
    // already gone
  }
}

async function restartClient() {
  await stopClient();
  await startClient();
}

/** A task that runs `servoc COMMAND FILE ARGS...`, its output read by `$servoc`. */
function makeTask(definition, scope) {
  const file = definition.file || '${file}';
  const args = [definition.command, file, ...(definition.args || [])];
  const task = new vscode.Task(
    definition,
    scope || vscode.TaskScope.Workspace,
    `${definition.command} ${definition.file ? path.basename(definition.file) : 'current file'}`,
    TASK_TYPE,
    new vscode.ProcessExecution(servocCommand(), args),
    ['$servoc'],
  );
  if (definition.command === 'lint') task.group = vscode.TaskGroup.Build;
  return task;
}

const taskProvider = {
  provideTasks() {
    return ['lint', 'plan', 'compile', 'verify'].map((command) => makeTask({ type: TASK_TYPE, command }));
  },
  resolveTask(task) {
    const definition = task.definition;
    if (!definition || definition.type !== TASK_TYPE || !definition.command) return undefined;
    const resolved = makeTask(definition, task.scope);
    resolved.name = task.name;
    return resolved;
  },
};

async function activate(context) {
  output = vscode.window.createOutputChannel('servoc');
  context.subscriptions.push(
    output,
    vscode.tasks.registerTaskProvider(TASK_TYPE, taskProvider),
    vscode.commands.registerCommand('servoc.restartServer', restartClient),
    vscode.workspace.onDidChangeConfiguration((event) => {
      if (event.affectsConfiguration('servoc.path')) restartClient();
    }),
    { dispose: () => void stopClient() },
  );
  await startClient();
}

function deactivate() {
  return stopClient();
}

module.exports = { activate, deactivate };
