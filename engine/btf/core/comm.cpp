#include <btf/core/comm.h>
#include <btf/core/error.h>
#include <btf/core/hash.h>

#include <cstring>

namespace btf {

namespace {
class LocalComm final : public Comm {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  std::string describe() const override { return "local"; }
  void barrier() override {}
  std::vector<std::string> allgather(const std::string& mine) override { return {mine}; }
  void broadcast(std::string&, int) override {}
  std::vector<std::string> gather(const std::string& mine, int) override { return {mine}; }
  void sumExact(std::vector<Exact>&) override {}
};
}  // namespace

Comm& localComm() {
  static LocalComm c;
  return c;
}

void collectively(Comm& comm, const std::function<void()>& fn) {
  if (!comm.distributed()) return fn();
  std::string failure;
  try {
    fn();
  } catch (const Error& e) {
    failure = std::string(1, '\1') + e.what();
  }
  const std::vector<std::string> all = comm.allgather(failure);
  int failed = 0, first = -1;
  for (int r = 0; r < int(all.size()); ++r)
    if (!all[size_t(r)].empty()) {
      ++failed;
      if (first < 0) first = r;
    }
  if (first < 0) return;
  const std::string msg = all[size_t(first)].substr(1);
  if (failed == comm.size()) throw CollectiveError(msg);  // every rank: the same request error
  throw CollectiveError("rank " + std::to_string(first) + " of " + std::to_string(comm.size()) +
                        ": " + msg);
}

void requireSame(Comm& comm, const std::string& what, const std::string& value) {
  if (!comm.distributed()) return;
  const std::string mine = hex64(checksum64(value.data(), value.size()));
  const std::vector<std::string> all = comm.allgather(mine);
  for (int r = 1; r < int(all.size()); ++r)
    if (all[size_t(r)] != all[0])
      throw CollectiveError("ranks disagree on " + what + ": rank 0 has " + all[0] + ", rank " +
                            std::to_string(r) + " has " + all[size_t(r)] +
                            " (every rank must run the same btfsim binary with the same request "
                            "and see the same input files)");
}

std::string packDoubles(const std::vector<double>& v) {
  std::string s(v.size() * sizeof(double), '\0');
  if (!v.empty()) std::memcpy(s.data(), v.data(), s.size());
  return s;
}

std::vector<double> unpackDoubles(const std::string& s) {
  BTF_CHECK(s.size() % sizeof(double) == 0);
  std::vector<double> v(s.size() / sizeof(double));
  if (!v.empty()) std::memcpy(v.data(), s.data(), s.size());
  return v;
}

std::vector<double> sumInRankOrder(Comm& comm, const std::vector<double>& mine) {
  if (!comm.distributed()) return mine;
  const std::vector<std::string> all = comm.allgather(packDoubles(mine));
  std::vector<double> sum(mine.size(), 0.0);
  for (const std::string& s : all) {
    const std::vector<double> v = unpackDoubles(s);
    BTF_CHECK_MSG(v.size() == sum.size(), "ranks sent sums of different lengths");
    for (size_t i = 0; i < v.size(); ++i) sum[i] += v[i];
  }
  return sum;
}

}  // namespace btf
