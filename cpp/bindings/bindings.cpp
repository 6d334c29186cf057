/// @file bindings.cpp
/// @brief The whole Python binding of the core, in one place. Integration releases the GIL so
/// that Python threads run simulations in parallel; results come back as numpy arrays that
/// view the C++ result (no copy).

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>

#include "vadsim/integrator.hpp"

namespace py = pybind11;
using namespace vadsim;

namespace {

Modes modes_from(const std::vector<int>& m) {
  if (m.size() != kSurfaces) throw std::invalid_argument("modes must have 5 entries");
  Modes out{};
  for (int s = 0; s < kSurfaces; ++s) {
    if (m[s] < 0 || m[s] > 2) throw std::invalid_argument("a contact mode is 0, 1 or 2");
    out[s] = static_cast<ContactMode>(m[s]);
  }
  return out;
}

template <typename T, typename F>
py::array_t<T> event_column(const RunResult& r, F get) {
  py::array_t<T> a(static_cast<py::ssize_t>(r.events.size()));
  auto m = a.template mutable_unchecked<1>();
  for (size_t i = 0; i < r.events.size(); ++i) m(static_cast<py::ssize_t>(i)) = get(r.events[i]);
  return a;
}

/// @brief SolverError and the enums: the vocabulary the other classes use.
void bind_errors_and_enums(py::module_& m) {
  py::register_exception<SolverError>(m, "SolverError", PyExc_RuntimeError);

  py::enum_<ContactLawKind>(m, "ContactLawKind")
      .value("KelvinVoigt", ContactLawKind::KelvinVoigt)
      .value("KelvinVoigtNoTension", ContactLawKind::KelvinVoigtNoTension)
      .value("HuntCrossley", ContactLawKind::HuntCrossley)
      .value("PowerDamping", ContactLawKind::PowerDamping)
      .value("PowerDampingImpact", ContactLawKind::PowerDampingImpact);
  py::enum_<Method>(m, "Method").value("BDF", Method::BDF).value("Adams", Method::Adams);
  py::enum_<Record>(m, "Record")
      .value("None_", Record::None)
      .value("Window", Record::Window)
      .value("All", Record::All);
  py::enum_<Steady>(m, "Steady").value("Full", Steady::Full).value("Auto", Steady::Auto);
}

/// @brief Params with one property per parameter of param_table(), pickling and the name table.
void bind_params(py::module_& m) {
  auto params = py::class_<Params>(m, "Params", "Table 2.1 parameters plus l0, wob, law options");
  params.def(py::init<>())
      .def_readwrite("law", &Params::law)
      .def("validate", &Params::validate)
      .def("gap", &Params::gap)
      .def("spring_length", &Params::spring_length)
      .def("excitation_hz", &Params::excitation_hz, py::arg("flow_gpm"))
      .def("flow_range_gpm", &Params::flow_range_gpm,
           "The flow rates (gal/min) whose excitation lies in EXCITATION_HZ_RANGE")
      .def("get", [](const Params& p, const std::string& n) { return get_param(p, n); })
      .def("set", [](Params& p, const std::string& n, double v) { set_param(p, n, v); })
      .def(py::pickle(
          [](const Params& p) {
            py::dict d;
            for (const auto& info : param_table()) d[info.name] = p.*info.member;
            d["law"] = static_cast<int>(p.law);
            return d;
          },
          [](const py::dict& d) {
            Params p;
            // A name missing from an older pickle keeps its default (theta0, L_gap: unset).
            for (const auto& info : param_table())
              if (d.contains(info.name)) p.*info.member = d[info.name].cast<double>();
            p.law = static_cast<ContactLawKind>(d["law"].cast<int>());
            return p;
          }));
  for (const auto& info : param_table()) {
    auto member = info.member;
    params.def_property(
        info.name, [member](const Params& p) { return p.*member; },
        [member](Params& p, double v) { p.*member = v; });
  }
  m.def("param_table", [] {
    py::list out;
    for (const auto& info : param_table()) {
      const char* rule = info.rule == ParamInfo::Rule::Positive      ? "positive"
                         : info.rule == ParamInfo::Rule::NonNegative ? "non-negative"
                         : info.rule == ParamInfo::Rule::Exponent    ? "exponent"
                         : info.rule == ParamInfo::Rule::Optional    ? "optional"
                                                                     : "finite";
      out.append(py::make_tuple(info.name, info.unit, info.meaning, rule, info.lo, info.hi));
    }
    return out;
  });
}

/// @brief The built-in extra physics terms (held by shared_ptr: a Model shares them).
void bind_extra_forces(py::module_& m) {
  py::class_<ExtraForce, std::shared_ptr<ExtraForce>>(m, "ExtraForce")
      .def_property_readonly("name", &ExtraForce::name);
  py::class_<HydraulicForce, ExtraForce, std::shared_ptr<HydraulicForce>>(m, "HydraulicForce")
      .def(py::init<int, double, double>(), py::arg("dof"), py::arg("c"), py::arg("n") = 2.0);
  py::class_<CoulombFriction, ExtraForce, std::shared_ptr<CoulombFriction>>(m, "CoulombFriction")
      .def(py::init<int, int, double, double, double, double>(), py::arg("dof_a"),
           py::arg("dof_b"), py::arg("force"), py::arg("v_eps"),
           py::arg("static_force") = std::nan(""), py::arg("v_s") = 0.05);
  py::class_<SpringDashpot, ExtraForce, std::shared_ptr<SpringDashpot>>(m, "SpringDashpot")
      .def(py::init<int, int, double, double>(), py::arg("dof_a"), py::arg("dof_b"),
           py::arg("k"), py::arg("c"));
}

/// @brief Model: construction and the pure evaluations tests and fits call.
void bind_model(py::module_& m) {
  py::class_<Model>(m, "Model")
      .def(py::init([](const Params& p, const std::vector<std::shared_ptr<ExtraForce>>& ex) {
             return Model(p, std::vector<ExtraForcePtr>(ex.begin(), ex.end()));
           }),
           py::arg("params"), py::arg("extras") = std::vector<std::shared_ptr<ExtraForce>>{})
      .def_property_readonly("params", &Model::params)
      .def_property_readonly("static_positions", &Model::static_positions)
      .def_property_readonly("x_top", &Model::x_top)
      .def_property_readonly("rest_phase", &Model::rest_phase,
                             "The excitation phase at rest theta0 the run uses (rad)")
      .def("indentation",
           [](const Model& mo, int s, const State& y) {
             if (s < 0 || s >= kSurfaces) throw std::invalid_argument("surface index 0..4");
             return mo.indentation(s, y);
           })
      .def("rhs",
           [](const Model& mo, double t, double flow, const State& y, const std::vector<int>& md) {
             State yd;
             mo.rhs(t, flow, y, modes_from(md), yd);
             return yd;
           })
      .def("jacobian",
           [](const Model& mo, double t, double flow, const State& y, const std::vector<int>& md) {
             Mat14 J;
             mo.jacobian(t, flow, y, modes_from(md), J);
             return J;
           })
      .def("energy", [](const Model& mo, const State& y, const std::vector<int>& md) {
        return mo.energy(y, modes_from(md));
      });
}

/// @brief RunOptions, field by field.
void bind_run_options(py::module_& m) {
  py::class_<RunOptions>(m, "RunOptions")
      .def(py::init<>())
      .def_readwrite("flow_gpm", &RunOptions::flow_gpm)
      .def_readwrite("cycles", &RunOptions::cycles)
      .def_readwrite("analyse_cycles", &RunOptions::analyse_cycles)
      .def_readwrite("method", &RunOptions::method)
      .def_readwrite("rtol", &RunOptions::rtol)
      .def_readwrite("atol", &RunOptions::atol)
      .def_readwrite("max_step", &RunOptions::max_step)
      .def_readwrite("record", &RunOptions::record)
      .def_readwrite("output_rate_hz", &RunOptions::output_rate_hz)
      .def_readwrite("accelerations_only", &RunOptions::accelerations_only)
      .def_readwrite("summary_rate_hz", &RunOptions::summary_rate_hz)
      .def_readwrite("peak_window_s", &RunOptions::peak_window_s)
      .def_readwrite("max_steps", &RunOptions::max_steps)
      .def_readwrite("max_events", &RunOptions::max_events)
      .def_readwrite("initial_state", &RunOptions::initial_state)
      .def_readwrite("initial_displacement", &RunOptions::initial_displacement)
      .def_readwrite("steady", &RunOptions::steady)
      .def_readwrite("steady_max_period", &RunOptions::steady_max_period)
      .def_readwrite("steady_min_cycles", &RunOptions::steady_min_cycles)
      .def_readwrite("steady_confirm_cycles", &RunOptions::steady_confirm_cycles)
      .def_readwrite("steady_drift_cycles", &RunOptions::steady_drift_cycles)
      .def_readwrite("steady_tol", &RunOptions::steady_tol)
      .def_readwrite("orbit_rate_hz", &RunOptions::orbit_rate_hz)
      .def_readwrite("orbit_replaces_window", &RunOptions::orbit_replaces_window)
      .def("steady_tolerance", &RunOptions::steady_tolerance)
      .def("step_budget", &RunOptions::step_budget)
      .def("event_budget", &RunOptions::event_budget)
      .def("validate", py::overload_cast<>(&RunOptions::validate, py::const_))
      .def("validate", py::overload_cast<const Params&>(&RunOptions::validate, py::const_),
           py::arg("params"));
}

/// @brief The result types, read-only: numpy views of the C++ arrays.
void bind_results(py::module_& m) {
  py::class_<SolverStats>(m, "SolverStats")
      .def_readonly("steps", &SolverStats::steps)
      .def_readonly("rhs_evals", &SolverStats::rhs_evals)
      .def_readonly("jac_evals", &SolverStats::jac_evals)
      .def_readonly("lin_setups", &SolverStats::lin_setups)
      .def_readonly("err_test_fails", &SolverStats::err_test_fails)
      .def_readonly("nonlin_iters", &SolverStats::nonlin_iters)
      .def_readonly("nonlin_conv_fails", &SolverStats::nonlin_conv_fails)
      .def_readonly("root_evals", &SolverStats::root_evals)
      .def_readonly("reinits", &SolverStats::reinits);

  py::class_<WindowSummary>(m, "WindowSummary")
      .def_readonly("t0", &WindowSummary::t0)
      .def_readonly("t1", &WindowSummary::t1)
      .def_readonly("rate_hz", &WindowSummary::rate_hz)
      .def_readonly("samples", &WindowSummary::samples)
      .def_readonly("onsets", &WindowSummary::onsets)
      .def_readonly("impulse_mean", &WindowSummary::impulse_mean)
      .def_readonly("impulse_pos", &WindowSummary::impulse_pos)
      .def_readonly("window_peaks", &WindowSummary::window_peaks);

  py::class_<SteadyInfo>(m, "SteadyInfo")
      .def_readonly("enabled", &SteadyInfo::enabled)
      .def_readonly("period", &SteadyInfo::period)
      .def_readonly("detected_cycle", &SteadyInfo::detected_cycle)
      .def_readonly("stopped_cycle", &SteadyInfo::stopped_cycle)
      .def_readonly("residual", &SteadyInfo::residual)
      .def_readonly("tolerance", &SteadyInfo::tolerance)
      .def_readonly("window_on_orbit", &SteadyInfo::window_on_orbit);

  py::class_<RunResult>(m, "RunResult")
      .def_readonly("flow_gpm", &RunResult::flow_gpm)
      .def_readonly("f_exc_hz", &RunResult::f_exc_hz)
      .def_readonly("t_end", &RunResult::t_end)
      .def_readonly("t", &RunResult::t)
      .def_readonly("x", &RunResult::x)
      .def_readonly("v", &RunResult::v)
      .def_readonly("a", &RunResult::a)
      .def_readonly("fc", &RunResult::fc)
      .def_readonly("fh", &RunResult::fh)
      .def_readonly("poincare_t", &RunResult::poincare_t)
      .def_readonly("poincare", &RunResult::poincare)
      .def_readonly("summary", &RunResult::summary)
      .def_readonly("stats", &RunResult::stats)
      .def_readonly("y_end", &RunResult::y_end)
      .def_readonly("x_static", &RunResult::x_static)
      .def_readonly("steady", &RunResult::steady)
      .def_readonly("orbit_t", &RunResult::orbit_t)
      .def_readonly("orbit_a", &RunResult::orbit_a)
      .def_readonly("orbit_corner_t", &RunResult::orbit_corner_t)
      .def_readonly("orbit_corner_before", &RunResult::orbit_corner_before)
      .def_readonly("orbit_corner_after", &RunResult::orbit_corner_after)
      .def_readonly("orbit_period_s", &RunResult::orbit_period_s)
      .def_property_readonly("event_t",
                             [](const RunResult& r) {
                               return event_column<double>(
                                   r, [](const ContactEvent& e) { return e.t; });
                             })
      .def_property_readonly("event_surface",
                             [](const RunResult& r) {
                               return event_column<int>(
                                   r, [](const ContactEvent& e) { return e.surface; });
                             })
      .def_property_readonly("event_kind",
                             [](const RunResult& r) {
                               return event_column<int>(r, [](const ContactEvent& e) {
                                 return static_cast<int>(e.kind);
                               });
                             })
      .def_property_readonly("event_rel_velocity", [](const RunResult& r) {
        return event_column<double>(r, [](const ContactEvent& e) { return e.rel_velocity; });
      });
}

/// @brief True on the interpreter's main thread, the only one where Python runs signal
/// handlers (PyErr_CheckSignals does nothing elsewhere).
bool on_main_thread() {
  const auto main = py::module_::import("threading").attr("main_thread")().attr("ident");
  return main.cast<unsigned long>() == PyThread_get_thread_ident();
}

/// @brief The process-wide stop request: set from Python (request_interrupt, e.g. by the
/// CLI's or a pool helper's Ctrl-C handling) and read by every run in progress, in any thread,
/// without the GIL. Python runs signal handlers on the main thread only, so this flag is how a
/// Ctrl-C reaches runs in worker threads.
std::atomic<bool> g_interrupt_requested{false};

/// @brief Ctrl-C during a run: every kInterruptCheckEvery steps the run looks at the stop
/// request and, on the main thread, takes the GIL back for a moment and lets Python run its
/// pending signal handlers. A handler that raises (SIGINT's default raises KeyboardInterrupt)
/// or a stop request stops the run, and simulate raises (KeyboardInterrupt for a request).
bool python_signal_pending() {
  if (g_interrupt_requested.load(std::memory_order_relaxed)) return true;
  py::gil_scoped_acquire gil;
  return PyErr_CheckSignals() != 0;
}

bool interrupt_requested() { return g_interrupt_requested.load(std::memory_order_relaxed); }

/// @brief simulate with the GIL released, so Python threads run simulations in parallel.
void bind_simulate(py::module_& m) {
  m.def(
      "simulate",
      [](const Model& model, const RunOptions& opts) {
        const InterruptCheck check = on_main_thread() ? InterruptCheck(python_signal_pending)
                                                      : InterruptCheck(interrupt_requested);
        try {
          py::gil_scoped_release release;
          return simulate(model, opts, check);
        } catch (const Interrupted& e) {
          // The GIL is held again. A signal handler's exception may be pending: raise it;
          // a stop request raises KeyboardInterrupt. Either with a note of how far the run got.
          if (!PyErr_Occurred()) PyErr_SetNone(PyExc_KeyboardInterrupt);
          py::error_already_set err;
          err.value().attr("add_note")(e.what());
          throw err;
        }
      },
      py::arg("model"), py::arg("options"),
      "Run the model (GIL released). Raises SolverError on solver failure, ValueError on bad "
      "options, the exception of a signal handler (KeyboardInterrupt for Ctrl-C) when a "
      "signal arrives during a run on the main thread, and KeyboardInterrupt in any thread "
      "when request_interrupt() was called.");
  m.def(
      "request_interrupt", [] { g_interrupt_requested.store(true); },
      "Ask every run in progress in this process, in any thread, to stop within "
      "kInterruptCheckEvery steps (it raises KeyboardInterrupt); runs started before "
      "clear_interrupt() stop at once.");
  m.def(
      "clear_interrupt", [] { g_interrupt_requested.store(false); },
      "Withdraw request_interrupt(): runs go to their end again.");
  m.def("interrupt_requested", &interrupt_requested,
        "Whether request_interrupt() is in force.");
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "vadsim C++ core: the 7-DOF vibro-impact model integrated by CVODE";
  m.attr("N_DOF") = kDof;
  m.attr("N_SURFACES") = kSurfaces;
  m.attr("EXCITATION_HZ_RANGE") = py::make_tuple(kMinExcitationHz, kMaxExcitationHz);
#ifdef VADSIM_VERSION
  m.attr("__version__") = VADSIM_VERSION;  // pyproject.toml's, passed in by CMake
#endif
  bind_errors_and_enums(m);
  bind_params(m);
  bind_extra_forces(m);
  bind_model(m);
  bind_run_options(m);
  bind_results(m);
  bind_simulate(m);
}
