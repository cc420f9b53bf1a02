// trompo-simulate: the command-line face of the library.
//
//   trompo-simulate --case ht1 --scheme simo-kappa --dt 0.001 --t-end 10 --every 100
//
// Writes one CSV row per output step:
//   t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations
// Exit status: 0 done; 2 invalid input (one line on stderr, no rows written);
// 3 a step failed (rows up to the last good state written, stderr names t and why).
//
// With --ensemble FILE, every initial state of FILE is integrated (across cores) and one
// row per member is written: its final state (docs/python.md "Ensembles").
//
// The logic (flags, checks, scenes, schemes, rows) is in simulate/simulate_core.hpp,
// shared with the Python module; this file is the program around it.
#include "simulate/simulate_core.hpp"

namespace {

using namespace trompo_simulate;

/// --ensemble FILE: read, run, write one row per member; exit 3 if any member failed.
int run_ensemble_file(const Config& c, std::FILE*& out) {
  const EnsembleInput input = read_ensemble(c);
  if (!c.csv.empty()) {
    out = std::fopen(c.csv.c_str(), "w");
    if (!out) throw invalid_input("--csv: cannot open '" + c.csv + "': " + std::strerror(errno));
  }
  if (!c.adaptive.t_eval.empty() || !c.adaptive.events.empty())
    throw invalid_input(std::string(c.adaptive.t_eval.empty() ? "--event" : "--t-eval") +
                        ": not with --ensemble FILE (one row per member; trompo.ensemble gives them from Python)");
  EnsembleRun run(input);
  const int code = simulate(c, run);
  for (const std::string& m : run.messages) std::fprintf(stderr, "trompo-simulate: %s\n", m.c_str());
  write_ensemble(out, run);
  long long recovered = 0, members_recovered = 0;
  for (const auto& s : run.summaries) {  // fixed steps only (adaptive members have no recovery)
    recovered += s.recovered;
    members_recovered += s.recovered > 0;
  }
  if (recovered > 0)
    std::fprintf(stderr, "trompo-simulate: %lld interval(s) recovered by sub-stepping in %lld member(s)\n", recovered,
                 members_recovered);
  if (const std::size_t failed = run.failed()) {
    std::fflush(out);
    std::size_t first = 0;
    while (run.ok(first)) ++first;
    std::fprintf(stderr, "trompo-simulate: %zu of %zu member(s) failed%s; first: member %zu at t = %.17g: %s\n", failed,
                 run.states.size(), run.adaptive.empty() ? ", not recovered by sub-stepping" : "", first,
                 run.states[first].time, run.reason(first).c_str());
  }
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace trompo;
  Config c;
  std::FILE* out = stdout;
  try {
    c = parse(argc, argv);
    validate(c);
    int code = 0;
    if (!c.ensemble.empty()) {
      code = run_ensemble_file(c, out);
    } else {
      if (!c.csv.empty()) {
        out = std::fopen(c.csv.c_str(), "w");
        if (!out) throw invalid_input("--csv: cannot open '" + c.csv + "': " + std::strerror(errno));
      }
      CsvSink sink(out);
      code = simulate(c, sink);
    }
    if (out != stdout) std::fclose(out);
    return code;
  } catch (const invalid_input& e) {
    std::fprintf(stderr, "trompo-simulate: %s\n", e.what());
    return 2;
  }
}
