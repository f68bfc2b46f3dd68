#include "server/http_server.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace hocurve::server {
namespace {

thread_local int t_socket = -1;
thread_local bool t_close_after = false;

/// poll() on one socket, retried on EINTR; the revents, 0 on timeout.
short poll_one(int fd, short events, int timeout_ms) {
  pollfd p = {fd, events, 0};
  int n;
  do {
    n = ::poll(&p, 1, timeout_ms);
  } while (n < 0 && errno == EINTR);
  return n > 0 ? p.revents : 0;
}

int timeout_ms(time_t sec, time_t usec) { return (int)std::min<long long>((long long)sec * 1000 + usec / 1000, 1 << 30); }

/// The socket of one connection, for all its requests: bytes read past the end of one request
/// stay in `buf_` for the next (cpp-httplib's SocketStream is made anew per request and loses them).
class ConnectionStream : public httplib::Stream {
 public:
  ConnectionStream(int sock, int read_ms, int write_ms) : sock_(sock), read_ms_(read_ms), write_ms_(write_ms) {}

  bool buffered() const { return pos_ < end_; }

  bool is_readable() const override { return buffered() || (poll_one(sock_, POLLIN, read_ms_) & (POLLIN | POLLHUP | POLLERR)); }

  /// Writable unless reset: a client that only shut down its sending side still reads the answer.
  bool is_writable() const override {
    const short r = poll_one(sock_, POLLOUT, write_ms_);
    return (r & POLLOUT) && !(r & (POLLERR | POLLHUP));
  }

  ssize_t read(char* ptr, size_t size) override {
    if (!buffered()) {
      if (!is_readable()) return -1;
      if (size >= sizeof buf_) return recv_some(ptr, size);
      const ssize_t n = recv_some(buf_, sizeof buf_);
      if (n <= 0) return n;
      pos_ = 0;
      end_ = (size_t)n;
    }
    const size_t n = std::min(size, end_ - pos_);
    std::memcpy(ptr, buf_ + pos_, n);
    pos_ += n;
    return (ssize_t)n;
  }

  ssize_t write(const char* ptr, size_t size) override {
    if (!is_writable()) return -1;
    ssize_t n;
    do {
      n = ::send(sock_, ptr, size, MSG_NOSIGNAL);
    } while (n < 0 && errno == EINTR);
    return n;
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override { address(true, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address(false, ip, port); }
  socket_t socket() const override { return sock_; }

 private:
  ssize_t recv_some(char* ptr, size_t size) {
    ssize_t n;
    do {
      n = ::recv(sock_, ptr, size, 0);
    } while (n < 0 && errno == EINTR);
    return n;
  }

  void address(bool peer, std::string& ip, int& port) const {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    if ((peer ? ::getpeername(sock_, (sockaddr*)&addr, &len) : ::getsockname(sock_, (sockaddr*)&addr, &len)) != 0) return;
    char host[NI_MAXHOST], serv[NI_MAXSERV];
    if (::getnameinfo((sockaddr*)&addr, len, host, sizeof host, serv, sizeof serv, NI_NUMERICHOST | NI_NUMERICSERV) != 0)
      return;
    ip = host;
    port = std::atoi(serv);
  }

  int sock_, read_ms_, write_ms_;
  char buf_[4096];
  size_t pos_ = 0, end_ = 0;
};

}  // namespace

int current_connection_socket() { return t_socket; }

void close_connection_after_response() { t_close_after = true; }

bool HttpServer::process_and_close_socket(socket_t sock) {
  ConnectionStream strm(sock, timeout_ms(read_timeout_sec_, read_timeout_usec_),
                        timeout_ms(write_timeout_sec_, write_timeout_usec_));
  t_socket = sock;
  bool ret = false;
  // As the library's loop: at most keep_alive_max_count_ requests (the last one's answer says
  // Connection: close), an idle connection let go after keep_alive_timeout_sec_; but a request
  // already read ahead is served at once.
  for (size_t left = keep_alive_max_count_; left > 0 && svr_sock_ != INVALID_SOCKET; --left) {
    if (!strm.buffered()) {
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(keep_alive_timeout_sec_);
      bool readable = false;
      while (!readable && svr_sock_ != INVALID_SOCKET && std::chrono::steady_clock::now() < deadline)
        readable = poll_one(sock, POLLIN, 100) != 0;  // data, EOF or error: process_request finds out which
      if (!readable) break;
    }
    t_close_after = false;
    bool closed = false;
    ret = process_request(strm, left == 1, closed, nullptr);
    if (!ret || closed || t_close_after) break;
  }
  t_socket = -1;
  t_close_after = false;
  ::shutdown(sock, SHUT_RDWR);
  ::close(sock);
  return ret;
}

bool PeerWatch::gone() {
  if (fd_ < 0) return false;
  short r = poll_one(fd_, POLLRDHUP, 0);
  if (r & (POLLHUP | POLLERR)) return true;  // reset (or both directions shut)
  if (!(r & POLLRDHUP) || probed_) return false;
  if (!http11_) return true;
  probed_ = true;
  static const char probe[] = "HTTP/1.1 100 Continue\r\n\r\n";
  if (::send(fd_, probe, sizeof probe - 1, MSG_NOSIGNAL | MSG_DONTWAIT) < 0 && errno != EAGAIN) return true;
  // A closed socket answers at once (one round trip); a slower reset is seen by a later call.
  return (poll_one(fd_, 0, 100) & (POLLHUP | POLLERR)) != 0;
}

}  // namespace hocurve::server
