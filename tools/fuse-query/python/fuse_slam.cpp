// Python binding of the planner client (module fuse_slam, Debian package python3-fuse-slam): the
// same calls and types as fuse/query/client.hpp, nothing more. Blocking calls release the GIL;
// a streaming callback runs on a transport thread and takes the GIL for the Python function.
//
//   import fuse_slam
//   client = fuse_slam.Client(fuse_slam.ClientOptions(domain_id=7))
//   client.wait_for_server(2000)
//   r = client.at(t)                       # or client.at(time.time(), fuse_slam.Clock.host_realtime)
//   if r.ok(): steer_by(r.estimate.position, r.estimate.orientation_xyzw)
#include <pybind11/functional.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>

#include "fuse/query/client.hpp"

namespace py = pybind11;
using namespace fuse::query;

namespace {

/// A Python callable held by C++ code that may drop it on a thread without the GIL.
std::shared_ptr<py::function> hold(py::function f) {
  return std::shared_ptr<py::function>(new py::function(std::move(f)), [](py::function* p) {
    py::gil_scoped_acquire gil;
    delete p;
  });
}

void subscribe(Client& client, const py::object& callback) {
  if (callback.is_none()) {
    py::gil_scoped_release release;
    client.subscribe({});
    return;
  }
  auto f = hold(callback.cast<py::function>());
  py::gil_scoped_release release;
  client.subscribe([f](const Result& r) {
    py::gil_scoped_acquire gil;
    try {
      (*f)(r);
    } catch (py::error_already_set& e) {
      e.discard_as_unraisable("fuse_slam.Client.subscribe callback");  // printed, never thrown into DDS
    }
  });
}

ClientOptions make_options(const py::kwargs& kwargs) {
  ClientOptions o;
  py::object self = py::cast(&o, py::return_value_policy::reference);
  for (const auto& [key, value] : kwargs) {
    const std::string name = py::str(key);
    if (!py::hasattr(self, name.c_str())) throw py::type_error("ClientOptions has no option '" + name + "'");
    py::setattr(self, name.c_str(), value);
  }
  return o;
}

/// Deletes a Client without the GIL: its destructor waits for a streaming callback in flight,
/// which needs the GIL to finish.
struct DeleteWithoutGil {
  void operator()(Client* client) const {
    py::gil_scoped_release release;
    delete client;
  }
};

}  // namespace

PYBIND11_MODULE(fuse_slam, m) {
  m.doc() = "FUSE-SLAM planner client: the estimate of the running estimator (fuse-state) at a time.";

  py::enum_<Error>(m, "Error")
      .value("ok", Error::ok)
      .value("bad_request", Error::bad_request)
      .value("not_ready", Error::not_ready)
      .value("unavailable", Error::unavailable)
      .value("internal", Error::internal)
      .value("out_of_range", Error::out_of_range)
      .value("not_tracking", Error::not_tracking);
  py::enum_<Status>(m, "Status")
      .value("not_initialised", Status::not_initialised)
      .value("interpolated", Status::interpolated)
      .value("propagated", Status::propagated)
      .value("too_old", Status::too_old)
      .value("in_future", Status::in_future)
      .value("relocalizing", Status::relocalizing)
      .value("lost", Status::lost);
  py::enum_<Clock>(m, "Clock")
      .value("sensor", Clock::sensor)
      .value("host_realtime", Clock::host_realtime)
      .value("host_monotonic", Clock::host_monotonic);

  py::class_<ClientOptions>(m, "ClientOptions", "How to reach the estimator (keyword arguments set the fields).")
      .def(py::init(&make_options))
      .def_readwrite("vendor", &ClientOptions::vendor)
      .def_readwrite("domain_id", &ClientOptions::domain_id)
      .def_readwrite("deadline_ms", &ClientOptions::deadline_ms)
      .def_readwrite("loopback_only", &ClientOptions::loopback_only)
      .def_readwrite("max_participants", &ClientOptions::max_participants)
      .def_readwrite("shared_memory", &ClientOptions::shared_memory)
      .def_readwrite("socket_buffer_bytes", &ClientOptions::socket_buffer_bytes)
      .def_readwrite("participant_name", &ClientOptions::participant_name)
      .def_readwrite("scheduler_slice_us", &ClientOptions::scheduler_slice_us)
      .def_readwrite("system_name", &ClientOptions::system_name)
      .def_readwrite("security", &ClientOptions::security)
      .def_readwrite("security_keystore", &ClientOptions::security_keystore)
      .def_readwrite("security_identity", &ClientOptions::security_identity)
      .def_readwrite("security_private_key", &ClientOptions::security_private_key)
      .def_readwrite("interfaces", &ClientOptions::interfaces)
      .def_readwrite("peers", &ClientOptions::peers);

  py::class_<HostClock>(m, "HostClock", "Host clock minus sensor clock: t_host = t + offset.")
      .def_readonly("known", &HostClock::known)
      .def_readonly("realtime_offset", &HostClock::realtime_offset)
      .def_readonly("monotonic_offset", &HostClock::monotonic_offset);

  py::class_<Estimate>(m, "Estimate", "The state of the IMU body in the world frame at time t (sensor clock).")
      .def_readonly("t", &Estimate::t)
      .def_readonly("position", &Estimate::position)
      .def_readonly("orientation_xyzw", &Estimate::orientation_xyzw)
      .def_readonly("velocity", &Estimate::velocity)
      .def_readonly("angular_velocity", &Estimate::angular_velocity)
      .def_readonly("pose_covariance", &Estimate::pose_covariance)
      .def_readonly("velocity_covariance", &Estimate::velocity_covariance)
      .def_readonly("status", &Estimate::status)
      .def_readonly("host_clock", &Estimate::host_clock)
      .def_readonly("frame_id", &Estimate::frame_id)
      .def_readonly("child_frame_id", &Estimate::child_frame_id);

  py::class_<Result>(m, "Result", "ok() only for a pose to steer by; otherwise error and message say why.")
      .def_readonly("error", &Result::error)
      .def_readonly("message", &Result::message)
      .def_readonly("estimate", &Result::estimate)
      .def("ok", &Result::ok)
      .def("__repr__", [](const Result& r) {
        return "<fuse_slam.Result " + std::string(to_string(r.error)) + " t=" + std::to_string(r.estimate.t) +
               " status=" + to_string(r.estimate.status) + ">";
      });

  py::class_<Client, std::unique_ptr<Client, DeleteWithoutGil>>(m, "Client", "A connection to fuse-state's query service; calls block at most deadline_ms.")
      .def(py::init<const ClientOptions&>(), py::arg("options") = ClientOptions{})
      .def("at", &Client::at, py::arg("t"), py::arg("clock") = Clock::sensor, py::call_guard<py::gil_scoped_release>(),
           "The estimate at time t (seconds on clock).")
      .def("latest", &Client::latest, py::call_guard<py::gil_scoped_release>(), "The newest estimate the server holds.")
      .def("newest", &Client::newest, py::call_guard<py::gil_scoped_release>(),
           "The newest streamed estimate (not_ready before the first; the first call subscribes).")
      .def("subscribe", &subscribe, py::arg("callback"),
           "Calls callback(Result) for every estimate fuse-state publishes (one per IMU sample), on a transport "
           "thread; None stops the calls.")
      .def("wait_for_server", &Client::wait_for_server, py::arg("timeout_ms"), py::call_guard<py::gil_scoped_release>());

  m.attr("MAX_QUERY_TIME") = kMaxQueryTime;
}
