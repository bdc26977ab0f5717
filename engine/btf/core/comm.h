// The processes of one job (docs/cluster.md): a communicator the use cases distribute their work
// over. One process (LocalComm) is the default everywhere — the studio, the tests, btfsim
// without mpirun; btfsim built with Open MPI and started by mpirun or srun gets the MPI one
// (engine/mpi, linked by btfsim only: the engine itself never includes mpi.h).
//
// Every collective is called by every rank in the same order. Results that the output depends
// on are combined in rank order (allgather, then a fixed-order sum), so a job writes the same
// bytes on any number of ranks.
#pragma once
#include <btf/core/error.h>
#include <btf/core/exact_sum.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace btf {

class Comm {
 public:
  virtual ~Comm() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  /// "local" or "Open MPI 4.1.4, 3 ranks on 1 node(s)".
  virtual std::string describe() const = 0;
  virtual void barrier() = 0;
  /// Every rank's bytes, in rank order, on every rank.
  virtual std::vector<std::string> allgather(const std::string& mine) = 0;
  /// `bytes` of `root` on every rank.
  virtual void broadcast(std::string& bytes, int root) = 0;
  /// Every rank's bytes on `root` in rank order (an empty vector elsewhere).
  virtual std::vector<std::string> gather(const std::string& mine, int root) = 0;
  /// Element-wise sums of every rank's `v` (exact integers: any order gives the same sums), on
  /// every rank.
  virtual void sumExact(std::vector<Exact>& v) = 0;

  /// Payload bytes this rank sent and received through the collectives so far.
  uint64_t bytesSent() const { return m_sent; }
  uint64_t bytesReceived() const { return m_received; }
  bool distributed() const { return size() > 1; }
  bool root() const { return rank() == 0; }

 protected:
  uint64_t m_sent = 0, m_received = 0;
};

/// An error every rank of the job threw together (collectively): each rank may end cleanly.
class CollectiveError : public Error {
 public:
  using Error::Error;
};

/// The one-process communicator (collectives are copies).
Comm& localComm();

/// Runs `fn` on every rank and agrees on the outcome: when it threw btf::Error on some ranks,
/// every rank throws CollectiveError with the first such rank's message ("rank R of N: " in front
/// when only some ranks failed), so no rank is left waiting in a later collective. `fn` itself
/// must hold no collective (a rank that failed before it would skip it): code with collectives
/// lets a rank's own error escape, and btfsim ends the job with MPI_Abort after printing it.
void collectively(Comm& comm, const std::function<void()>& fn);

/// Every rank must hold the same `value` (a request, a scene): otherwise every rank throws
/// CollectiveError "ranks disagree on WHAT: rank 0 …, rank R …".
void requireSame(Comm& comm, const std::string& what, const std::string& value);

/// Element-wise sums of every rank's values, added in rank order (the same bits on every rank
/// and for any arrival order).
std::vector<double> sumInRankOrder(Comm& comm, const std::vector<double>& mine);

/// Bytes <-> doubles, for the collectives.
std::string packDoubles(const std::vector<double>& v);
std::vector<double> unpackDoubles(const std::string& s);

}  // namespace btf
