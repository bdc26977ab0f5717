// The Open MPI communicator (docs/cluster.md). Only btfsim links this: the engine sees the Comm
// interface of btf/core/comm.h.
#pragma once
#include <btf/core/comm.h>

#include <memory>

namespace btf {

/// True when the process was started by mpirun/mpiexec or srun (the launcher's environment).
bool launchedByMpi();

class MpiComm final : public Comm {
 public:
  /// MPI_Init_thread (funneled: only the calling thread talks to MPI).
  MpiComm(int* argc, char*** argv);
  ~MpiComm() override;  // MPI_Finalize
  int rank() const override { return m_rank; }
  int size() const override { return m_size; }
  std::string describe() const override;
  void barrier() override;
  std::vector<std::string> allgather(const std::string& mine) override;
  void broadcast(std::string& bytes, int root) override;
  std::vector<std::string> gather(const std::string& mine, int root) override;
  void sumExact(std::vector<Exact>& v) override;
  /// Ranks sharing this rank's node (for the default thread count).
  int localSize() const { return m_localSize; }
  /// Ends every rank of the job (after the caller printed why).
  [[noreturn]] void abort(int code);

 private:
  int m_rank = 0, m_size = 1, m_localSize = 1, m_nodes = 1;
  std::string m_library;
  void* m_exactType = nullptr;  // MPI_Datatype and MPI_Op of the 128-bit sums
  void* m_exactOp = nullptr;
};

}  // namespace btf
