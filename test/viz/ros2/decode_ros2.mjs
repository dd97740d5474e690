// Decodes the ROS 2 samples the test captured from FUSE's services (DIR/<topic>_<n>.cdr, the raw
// DDS payloads of rt/... topics) with @foxglove/rosmsg2-serialization and the message definitions
// of @foxglove/rosmsg-msgs-common for Jazzy and for Humble, and checks them field by field against
// what FUSE itself published for the same time (DIR/expected.json, written by the test from
// FUSE's own topics). Exit code 0 when every check passed.
//   node decode_ros2.mjs DIR
import { readFile, readdir } from "node:fs/promises";
import { join } from "node:path";
import msgs from "@foxglove/rosmsg-msgs-common";
import serialization from "@foxglove/rosmsg2-serialization";

const { MessageReader } = serialization;
const dir = process.argv[2];
const expected = JSON.parse(await readFile(join(dir, "expected.json"), "utf8"));
let failures = 0, checks = 0;
function check(ok, what) {
  checks += 1;
  if (!ok) {
    failures += 1;
    if (failures < 20) console.error(`check failed: ${what}`);
  }
}
const near = (a, b, tol) => Math.abs(a - b) <= tol;
const time = (stamp) => stamp.sec + stamp.nanosec * 1e-9;
const key = (t) => Math.round(t * 1e6).toString();

/// A reader of `type` with every definition of the distribution (nested types are looked up by name).
function readerFor(distro, type) {
  const all = msgs[distro];
  return new MessageReader([all[type], ...Object.values(all).filter((d) => d.name !== type)]);
}

const files = (await readdir(dir)).filter((f) => f.endsWith(".cdr")).sort();
const byTopic = {};
for (const f of files) (byTopic[f.replace(/_[0-9]+\.cdr$/, "")] ??= []).push(f);
const summary = {};
for (const distro of ["ros2jazzy", "ros2humble"]) {
  const decoders = {
    odometry: readerFor(distro, "nav_msgs/Odometry"),
    tf: readerFor(distro, "tf2_msgs/TFMessage"),
    tf_static: readerFor(distro, "tf2_msgs/TFMessage"),
    scan: readerFor(distro, "sensor_msgs/PointCloud2"),
    map: readerFor(distro, "sensor_msgs/PointCloud2"),
    diagnostics: readerFor(distro, "diagnostic_msgs/DiagnosticArray"),
  };
  for (const [topic, list] of Object.entries(byTopic)) {
    const reader = decoders[topic];
    check(reader !== undefined, `a decoder for ${topic}`);
    if (!reader) continue;
    for (const f of list) {
      const bytes = await readFile(join(dir, f));
      const m = reader.readMessage(bytes);
      summary[topic] = (summary[topic] ?? 0) + 1;
      if (topic === "odometry") {
        const e = expected.odometry[key(time(m.header.stamp))];
        check(e !== undefined, `odometry at ${time(m.header.stamp)} matches a FUSE odometry sample`);
        if (!e) continue;
        check(m.header.frame_id === e.frame && m.child_frame_id === e.child_frame, `odometry frames ${m.header.frame_id} -> ${m.child_frame_id}`);
        const p = m.pose.pose.position, q = m.pose.pose.orientation;
        check(near(p.x, e.position[0], 1e-9) && near(p.y, e.position[1], 1e-9) && near(p.z, e.position[2], 1e-9), `odometry position ${f}`);
        const dot = Math.abs(q.x * e.orientation[0] + q.y * e.orientation[1] + q.z * e.orientation[2] + q.w * e.orientation[3]);
        check(near(dot, 1, 1e-9), `odometry orientation ${f}`);
        check(m.pose.covariance.length === 36 && near(m.pose.covariance[0], e.covariance_xx, 1e-12), `odometry covariance ${f}`);
        const speed = Math.hypot(m.twist.twist.linear.x, m.twist.twist.linear.y, m.twist.twist.linear.z);
        check(near(speed, e.speed, 1e-9), `odometry speed ${speed} (twist in the child frame keeps the speed ${e.speed})`);
      } else if (topic === "tf" || topic === "tf_static") {
        check(m.transforms.length === 1, `${topic}: one transform`);
        const tf = m.transforms[0];
        const e = expected[topic];
        check(tf.header.frame_id === e.parent && tf.child_frame_id === e.child, `${topic}: ${tf.header.frame_id} -> ${tf.child_frame_id}`);
        if (topic === "tf_static") {
          const v = tf.transform.translation;
          check(near(v.x, e.translation[0], 1e-12) && near(v.y, e.translation[1], 1e-12) && near(v.z, e.translation[2], 1e-12), "tf_static translation");
        } else {
          const o = expected.odometry[key(time(tf.header.stamp))];
          if (o) check(near(tf.transform.translation.x, o.position[0], 1e-9), `tf at ${time(tf.header.stamp)} is the odometry's pose`);
        }
      } else if (topic === "scan" || topic === "map") {
        check(m.height === 1 && m.fields.map((x) => x.name).join() === "x,y,z", `${topic}: an unordered x, y, z cloud`);
        check(m.fields.every((x) => x.datatype === 7 && x.count === 1) && m.point_step === 12 && !m.is_bigendian, `${topic}: float32 fields`);
        check(m.data.length === m.width * m.point_step && m.row_step === m.data.length, `${topic}: ${m.width} points of data`);
        const view = new DataView(m.data.buffer, m.data.byteOffset, m.data.byteLength);
        let sx = 0, sy = 0, sz = 0;
        for (let i = 0; i < m.width; ++i) {
          sx += view.getFloat32(12 * i, true);
          sy += view.getFloat32(12 * i + 4, true);
          sz += view.getFloat32(12 * i + 8, true);
        }
        if (topic === "scan") {
          const e = expected.scans[key(time(m.header.stamp))];
          check(e !== undefined, `scan at ${time(m.header.stamp)} matches an update/world_scan sample`);
          if (e) {
            check(m.width === e.points, `scan points ${m.width} vs ${e.points}`);
            check(near(sx, e.sum[0], 1e-3 * Math.max(1, Math.abs(e.sum[0]))) && near(sz, e.sum[2], 1e-3 * Math.max(1, Math.abs(e.sum[2]))), `scan coordinates ${f}`);
          }
          check(m.header.frame_id === expected.world_frame, `scan frame ${m.header.frame_id}`);
        } else {
          summary.map_points = m.width;
        }
      } else if (topic === "diagnostics") {
        check(m.status.length === 1 && expected.services.includes(m.status[0].name), `diagnostics from ${m.status[0]?.name}`);
        check([0, 1, 2, 3].includes(m.status[0].level), "diagnostics level");
        check(m.status[0].values.some((kv) => kv.key === "uptime_s"), "diagnostics values");
        (summary.diagnostics_from ??= new Set()).add(m.status[0].name);
      }
    }
  }
}
if (expected.map_points !== undefined) check(summary.map_points === expected.map_points, `map ${summary.map_points} points, the map server holds ${expected.map_points}`);
check(summary.diagnostics_from?.size === expected.services.length, `diagnostics from every service (${[...(summary.diagnostics_from ?? [])]})`);
console.log(JSON.stringify({ ...summary, diagnostics_from: [...(summary.diagnostics_from ?? [])], checks, failures }));
process.exit(failures ? 1 : 0);
