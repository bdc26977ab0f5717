#include "mpi_comm.h"

#include <btf/core/error.h>
#include <mpi.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

namespace btf {

namespace {
// Messages go in pieces of at most 1 GiB (MPI counts are int).
constexpr uint64_t kPiece = uint64_t(1) << 30;

void check(int rc, const char* what) {
  if (rc != MPI_SUCCESS) {
    char text[MPI_MAX_ERROR_STRING];
    int len = 0;
    MPI_Error_string(rc, text, &len);
    throw Error(std::string("MPI ") + what + " failed: " + std::string(text, size_t(len)));
  }
}

void sendBytes(const std::string& s, int to, int tag) {
  uint64_t n = s.size();
  check(MPI_Send(&n, 1, MPI_UINT64_T, to, tag, MPI_COMM_WORLD), "send");
  for (uint64_t o = 0; o < n; o += kPiece)
    check(MPI_Send(s.data() + o, int(std::min(kPiece, n - o)), MPI_BYTE, to, tag, MPI_COMM_WORLD),
          "send");
}

std::string recvBytes(int from, int tag) {
  uint64_t n = 0;
  check(MPI_Recv(&n, 1, MPI_UINT64_T, from, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE), "receive");
  std::string s(n, '\0');
  for (uint64_t o = 0; o < n; o += kPiece)
    check(MPI_Recv(s.data() + o, int(std::min(kPiece, n - o)), MPI_BYTE, from, tag, MPI_COMM_WORLD,
                   MPI_STATUS_IGNORE),
          "receive");
  return s;
}
}  // namespace

// MPI_Op for Exact (16 bytes, any alignment): inout += in.
void addExact(void* in, void* inout, int* len, MPI_Datatype*) {
  for (int i = 0; i < *len; ++i) {
    Exact a, b;
    std::memcpy(&a, static_cast<const char*>(in) + size_t(i) * 16, 16);
    std::memcpy(&b, static_cast<const char*>(inout) + size_t(i) * 16, 16);
    b += a;
    std::memcpy(static_cast<char*>(inout) + size_t(i) * 16, &b, 16);
  }
}

bool launchedByMpi() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
    if (std::getenv(v)) return true;
  return false;
}

MpiComm::MpiComm(int* argc, char*** argv) {
  int provided = 0;
  check(MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided), "init");
  MPI_Comm_rank(MPI_COMM_WORLD, &m_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &m_size);
  MPI_Comm local;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, m_rank, MPI_INFO_NULL, &local);
  MPI_Comm_size(local, &m_localSize);
  int localRank = 0;
  MPI_Comm_rank(local, &localRank);
  MPI_Comm_free(&local);
  int leader = localRank == 0 ? 1 : 0;
  MPI_Allreduce(&leader, &m_nodes, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  char lib[MPI_MAX_LIBRARY_VERSION_STRING];
  int len = 0;
  MPI_Get_library_version(lib, &len);
  m_library = std::string(lib, size_t(len));
  static MPI_Datatype type;
  static MPI_Op op;
  MPI_Type_contiguous(16, MPI_BYTE, &type);
  MPI_Type_commit(&type);
  MPI_Op_create(&addExact, 1, &op);
  m_exactType = &type;
  m_exactOp = &op;
  if (auto cut = m_library.find(','); cut != std::string::npos) m_library.resize(cut);
}

MpiComm::~MpiComm() {
  MPI_Finalize();
}

std::string MpiComm::describe() const {
  return m_library + ", " + std::to_string(m_size) + " rank(s) on " + std::to_string(m_nodes) +
         " node(s)";
}

void MpiComm::barrier() {
  check(MPI_Barrier(MPI_COMM_WORLD), "barrier");
}

std::vector<std::string> MpiComm::gather(const std::string& mine, int root) {
  constexpr int kTag = 71;
  std::vector<std::string> all;
  if (m_rank == root) {
    all.resize(size_t(m_size));
    for (int r = 0; r < m_size; ++r) {
      if (r == root) {
        all[size_t(r)] = mine;
        continue;
      }
      all[size_t(r)] = recvBytes(r, kTag);
      m_received += all[size_t(r)].size();
    }
  } else {
    sendBytes(mine, root, kTag);
    m_sent += mine.size();
  }
  return all;
}

void MpiComm::broadcast(std::string& bytes, int root) {
  uint64_t n = bytes.size();
  check(MPI_Bcast(&n, 1, MPI_UINT64_T, root, MPI_COMM_WORLD), "broadcast");
  if (m_rank != root) bytes.assign(n, '\0');
  for (uint64_t o = 0; o < n; o += kPiece)
    check(MPI_Bcast(bytes.data() + o, int(std::min(kPiece, n - o)), MPI_BYTE, root, MPI_COMM_WORLD),
          "broadcast");
  if (m_rank == root)
    m_sent += n * uint64_t(m_size - 1);
  else
    m_received += n;
}

void MpiComm::sumExact(std::vector<Exact>& v) {
  const MPI_Datatype type = *static_cast<MPI_Datatype*>(m_exactType);
  const MPI_Op op = *static_cast<MPI_Op*>(m_exactOp);
  constexpr size_t kMax = size_t(1) << 26;
  for (size_t o = 0; o < v.size(); o += kMax) {
    const int n = int(std::min(kMax, v.size() - o));
    check(MPI_Allreduce(MPI_IN_PLACE, v.data() + o, n, type, op, MPI_COMM_WORLD), "reduction");
  }
  // What a bandwidth-optimal allreduce (reduce-scatter + allgather) moves per rank: 2(N−1)/N of
  // the vector each way (Open MPI picks its algorithm by size; this is the figure to plan with).
  const uint64_t moved = 2 * v.size() * 16 * uint64_t(m_size - 1) / uint64_t(m_size);
  m_sent += moved;
  m_received += moved;
}

std::vector<std::string> MpiComm::allgather(const std::string& mine) {
  std::vector<std::string> all = gather(mine, 0);
  // Concatenated with lengths, then broadcast.
  std::string packed;
  if (m_rank == 0) {
    for (const std::string& s : all) {
      const uint64_t n = s.size();
      packed.append(reinterpret_cast<const char*>(&n), 8);
      packed += s;
    }
  }
  broadcast(packed, 0);
  if (m_rank != 0) {
    all.clear();
    size_t o = 0;
    for (int r = 0; r < m_size; ++r) {
      uint64_t n = 0;
      BTF_CHECK(o + 8 <= packed.size());
      std::memcpy(&n, packed.data() + o, 8);
      o += 8;
      BTF_CHECK(o + n <= packed.size());
      all.push_back(packed.substr(o, n));
      o += n;
    }
  }
  return all;
}

void MpiComm::abort(int code) {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::_Exit(code);
}

}  // namespace btf
