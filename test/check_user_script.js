// Copyright 2026 torquefree_ros maintainers
//
// Licensed under the Apache License, Version 2.0 (the "License");
// you may not use this file except in compliance with the License.
// You may obtain a copy of the License at
//
//     http://www.apache.org/licenses/LICENSE-2.0
//
// Unless required by applicable law or agreed to in writing, software
// distributed under the License is distributed on an "AS IS" BASIS,
// WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
// See the License for the specific language governing permissions and
// limitations under the License.

// A Foxglove/Lichtblick user script checked as the apps check it before running it, with the
// TypeScript compiler: compiled (strict, ES2022, CommonJS, the ES2022 library only, as
// /studio_script/index.ts), its `output` and `inputs` read, and the message definition of its output
// made from the type its default export returns (the rules of Lichtblick's datatype extraction:
// the type without null/undefined must be one type literal or interface, not a union, intersection
// or class, and each member a property with a name and a type). Given an event (JSON), the compiled
// script is also run on it.
//
//   node check_user_script.js TYPESCRIPT_DIR SCRIPT.ts [EVENT.json]
//
// Prints one JSON object: diagnostics (the compiler's), problems (the extraction's, in the apps'
// words), output, inputs, fields ([name, ROS type] of the output) and result (the run's).
"use strict";

const fs = require("fs");

const [typescriptDir, scriptPath, eventPath] = process.argv.slice(2);
const ts = require(typescriptDir);

const SCRIPT = "/studio_script/index.ts";
const source = fs.readFileSync(scriptPath, "utf8");
const options = {
  strict: true,
  target: ts.ScriptTarget.ES2022,
  module: ts.ModuleKind.CommonJS,
  lib: ["lib.es2022.d.ts"],
  types: [],
};

const host = ts.createCompilerHost(options);
const libraryFile = host.getSourceFile.bind(host);
host.getSourceFile = (name, ...rest) =>
  name === SCRIPT ? ts.createSourceFile(name, source, options.target, true) : libraryFile(name, ...rest);
const exists = host.fileExists.bind(host);
host.fileExists = (name) => name === SCRIPT || exists(name);
let javascript;
host.writeFile = (name, text) => {
  if (name.endsWith("/index.js")) {
    javascript = text;
  }
};

const program = ts.createProgram([SCRIPT], options, host);
program.emit();
const diagnostics = [
  ...program.getOptionsDiagnostics(),
  ...program.getGlobalDiagnostics(),
  ...program.getSyntacticDiagnostics(),
  ...program.getSemanticDiagnostics(),
].map((diagnostic) => ts.flattenDiagnosticMessageText(diagnostic.messageText, "\n"));

const checker = program.getTypeChecker();
const file = program.getSourceFile(SCRIPT);
const exported = checker.getExportsOfModule(checker.getSymbolAtLocation(file));
const problems = [];

// output: the apps read it from the text
const outputMatch = /^\s*export\s+const\s+output\s*=\s*("([^"]+)"|'([^']+)')/m.exec(source);
const output = outputMatch ? outputMatch[2] ?? outputMatch[3] : null;
if (output === null) {
  problems.push("Must include an output");
}

// inputs: an exported array literal of string literals
let inputs = null;
const inputsSymbol = exported.find((symbol) => symbol.escapedName === "inputs");
const inputsDeclaration = inputsSymbol?.declarations?.[0];
if (
  inputsDeclaration &&
  ts.isVariableDeclaration(inputsDeclaration) &&
  inputsDeclaration.initializer &&
  ts.isArrayLiteralExpression(inputsDeclaration.initializer) &&
  inputsDeclaration.initializer.elements.every(ts.isStringLiteral)
) {
  inputs = inputsDeclaration.initializer.elements.map((element) => element.text);
} else {
  problems.push("The exported 'inputs' variable must be an array of string literals");
}

function rosType(member) {
  switch (member.type.kind) {
    case ts.SyntaxKind.NumberKeyword:
      return "float64";
    case ts.SyntaxKind.StringKeyword:
      return "string";
    case ts.SyntaxKind.BooleanKeyword:
      return "bool";
    default:
      return ts.SyntaxKind[member.type.kind];
  }
}

// the output's definition, from the default export's return type
let fields = null;
function outputDeclaration() {
  const defaultSymbol = exported.find((symbol) => symbol.escapedName === "default");
  const functionNode = defaultSymbol?.declarations?.find(ts.isFunctionDeclaration);
  if (!functionNode) {
    return "Your script must default export a function";
  }
  const signatures = checker.getTypeAtLocation(functionNode).getCallSignatures();
  if (signatures.length !== 1) {
    return "The default export must be a function with one signature";
  }
  const returned = checker.getReturnTypeOfSignature(signatures[0]).getNonNullableType();
  if (returned.isIntersection() || returned.isClass() || returned.isUnion()) {
    return "The return type must be one type: no intersection, class or union";
  }
  const declarations = returned.getSymbol()?.declarations ?? [];
  const declaration =
    declarations.length === 1 ? declarations[0] : declarations.find(ts.isInterfaceDeclaration);
  if (!declaration || !(ts.isTypeLiteralNode(declaration) || ts.isInterfaceDeclaration(declaration))) {
    return "The return type must be a type literal or an interface";
  }
  return declaration;
}
const declaration = outputDeclaration();
if (typeof declaration === "string") {
  problems.push(declaration);
} else {
  fields = [];
  for (const member of declaration.members) {
    if (!member.name) {
      problems.push("Encountered type member with no name");
    } else if (!ts.isPropertySignature(member)) {
      problems.push(`Unexpected type member (kind ${member.kind})`);
    } else if (!member.type) {
      problems.push(`Member ${member.name.getText()} has no type`);
    } else {
      fields.push([member.name.getText(), rosType(member)]);
    }
  }
}

let result = null;
if (eventPath !== undefined && javascript !== undefined) {
  const module = { exports: {} };
  new Function("module", "exports", javascript)(module, module.exports);
  const event = JSON.parse(fs.readFileSync(eventPath, "utf8"));
  result = module.exports.default(event) ?? null;
}

console.log(JSON.stringify({ diagnostics, problems, output, inputs, fields, result }));
