// Faults on purpose: a scenario's `faults:` list (sim/scenario/scenario.h FaultClause), struck into
// the closed loop at their instants. Each fault begins at at_s and, where it has for_s, ends at
// at_s + for_s; both are events (`fault_begin`, `fault_end`, with `fault` = the kind and `car`), so
// expectations (recovers_within, no_gridlock), the report and the video see them. A fault draws no
// random number and shifts no stream: a run with a fault differs from the same run without it only
// by what the fault does. What each kind does:
//
//   v2i_partition   {car?, direction: up|down|both, for_s?}  the car's (every car's) messages in
//                   those directions are lost, in flight included (v2i_lost, detail
//                   "(v2i_partition)")
//   v2i_loss_burst  {car?, loss, for_s?}  each message is lost with probability `loss` on top of
//   the
//                   modeled loss (the link's own draw decides, so the burst shifts no delays)
//   server_restart  {for_s?}  the traffic-light server loses its state (holders, queues, leases),
//   as
//                   the lab's vtl.py does on a restart; with for_s it is down that long first and
//                   what reaches it meanwhile is lost; without, it is back at once
//   broker_outage   {for_s?}  the MQTT broker is away: every message of every car, both ways, is
//                   lost (the lab's clients keep clean sessions: nothing is queued for later)
//   car_stall       {car, for_s?}  the car's motor is dead: it gets throttle 0 whatever its driver
//                   commands (steering still works), so it rolls to a stop and stays; its board and
//                   intersection client run on. Without for_s it never recovers
//   node_crash      {car, node}  the node dies for the rest of the run (NodeGraph::CrashNode): its
//                   running job publishes nothing, nothing reaches it any more
//   node_hang       {car, node, for_s?}  the node's executor blocks (NodeGraph::HangNode): its
//                   current job's outputs wait, messages pile up in its keep-last queues (drops
//                   counted), timer ticks are overruns; it catches up when the hang ends
//   camera_freeze   {car, camera: color|depth, for_s?}  the camera publishes its last picture again
//                   and again under new stamps (SensorSuite::CameraFault::kFreeze)
//   camera_blackout {car, camera, for_s?}  the camera publishes black frames (depth: no return)
//   imu_bias_step   {car, gyro_bias_rad_per_s, for_s?}  the gyro's bias steps by that much; a
//                   gyro-integrated heading drifts with it, the magnetometer's does not
//                   (vehicle::StepGyroBias); for_s steps it back
//   localization_jump {car, dx_m?, dy_m?, dyaw_deg?}  the EKF's estimate jumps by that much, map
//                   frame (stack::JumpLocalizationEstimate); instantaneous
//
// A fault without for_s that disables something (car_stall, node_crash, node_hang, camera_*,
// v2i_*, broker_outage) lasts to the run's end and has no fault_end; an instantaneous one
// (server_restart without for_s, localization_jump, imu_bias_step without for_s: the bias stays,
// but the step is done) has its fault_end at its fault_begin. Unknown kinds, cars and nodes are
// errors naming the file, line and key (the scenario loader; nodes when the car's board is built).
#pragma once

#include <string>

#include "sim/scenario/scenario.h"

namespace autonomsim::sim {

// Each kind's arguments, checks and detail: sim/scenario/fault_kinds.h. Scheduling them into a
// run: Simulation::Impl::ScheduleFaults (sim/loop/faults.cc), one overload per kind.

}  // namespace autonomsim::sim
