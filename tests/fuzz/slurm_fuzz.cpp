// Fuzz target for the Slurm client's parsers (daemon/cluster/slurm.hpp): sbatch --parsable, squeue
// and sacct in their fixed formats, the plan header, state names. The first byte picks the
// parser. Links only hdrd_daemon_slurm.
//
// Invariants beyond "no crash": an accepted line set gives rows with a job id > 0, a known
// state whose name maps back to it, task indices below Slurm's array limit and at most
// kMaxRows rows; an error has a code and a one-line message.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "daemon/cluster/slurm.hpp"

namespace {

using namespace hdrd;
using namespace hdrd::daemon::slurm;

void check(bool ok) {
  if (!ok) std::abort();
}

void check_error(const Error& e) {
  check(!e.code.empty());
  check(!e.message.empty());
  check(e.message.find('\n') == std::string::npos);
}

void check_rows(const Result<std::vector<TaskStatus>>& r) {
  if (!r) return check_error(r.error());
  check(r->size() <= kMaxRows);  // a short range must not become millions of rows
  for (const auto& t : *r) {
    check(t.job_id > 0);
    auto s = map_state(t.slurm_state);
    check(s.ok() && *s == t.state);
    check(!t.array_task || *t.array_task < 4000001u);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string rest(reinterpret_cast<const char*>(data) + 1, size - 1);
  switch (data[0] % 5) {
    case 0: {
      auto id = parse_sbatch_parsable(rest);
      if (id) check(*id > 0);
      else check_error(id.error());
      break;
    }
    case 1: check_rows(parse_squeue(rest)); break;
    case 2: check_rows(parse_sacct(rest)); break;
    case 3: {
      auto h = parse_plan_header(rest, "/plans");
      if (!h) {
        check_error(h.error());
        break;
      }
      check(h->shards >= 1 && h->shards <= kMaxShards && h->frames >= 1 && h->work_dir.is_absolute());
      break;
    }
    case 4: {
      auto s = map_state(rest);
      if (s) check(to_string(*s).size() > 0);
      else check_error(s.error());
      break;
    }
  }
  return 0;
}
