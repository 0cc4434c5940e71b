// torquefree_ros: the simulator's kinetic energy T and momentum |H| as numbers, for Plot panels.
// /diagnostics carries them as text (diagnostic_msgs/KeyValue), which a Plot cannot draw.
export const inputs = ["/diagnostics"];
export const output = "/studio_script/torquefree_invariants";

type KeyValue = { key: string; value: string };
type Status = { name: string; values: KeyValue[] };
type Invariants = { [key: string]: number };

const KEYS = ["kinetic_energy", "angular_momentum", "kinetic_energy_drift", "angular_momentum_drift"];

export default function script(event: { message: { status: Status[] } }): Invariants | undefined {
  for (const status of event.message.status) {
    if (!status.name.endsWith(": simulation")) {
      continue; // another node's status on the same topic
    }
    const found: Invariants = {};
    for (const pair of status.values) {
      if (KEYS.includes(pair.key)) {
        found[pair.key] = Number(pair.value);
      }
    }
    if (KEYS.every((key) => key in found)) {
      return found;
    }
  }
  return undefined; // no sample yet (the node reports invariants once it has published one)
}
