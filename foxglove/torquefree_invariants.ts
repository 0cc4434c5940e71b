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

// torquefree_ros: the simulator's kinetic energy T and momentum |H| as numbers, for Plot panels.
// /diagnostics carries them as text (diagnostic_msgs/KeyValue), which a Plot cannot draw.
export const inputs = ["/diagnostics"];
export const output = "/studio_script/torquefree_invariants";

type KeyValue = { key: string; value: string };
type Status = { name: string; values: KeyValue[] };
// The output's message definition is made from this type: named numeric fields only (the apps reject
// an index signature, and a Plot path names a field).
type Invariants = {
  kinetic_energy: number;
  angular_momentum: number;
  kinetic_energy_drift: number;
  angular_momentum_drift: number;
};

const KEYS = ["kinetic_energy", "angular_momentum", "kinetic_energy_drift", "angular_momentum_drift"];

export default function script(event: { message: { status: Status[] } }): Invariants | undefined {
  for (const status of event.message.status) {
    if (!status.name.endsWith(": simulation")) {
      continue; // another node's status on the same topic
    }
    const text = new Map<string, string>();
    for (const pair of status.values) {
      text.set(pair.key, pair.value);
    }
    if (KEYS.every((key) => text.has(key))) {
      return {
        kinetic_energy: Number(text.get("kinetic_energy")),
        angular_momentum: Number(text.get("angular_momentum")),
        kinetic_energy_drift: Number(text.get("kinetic_energy_drift")),
        angular_momentum_drift: Number(text.get("angular_momentum_drift")),
      };
    }
  }
  return undefined; // no sample yet (the node reports invariants once it has published one)
}
