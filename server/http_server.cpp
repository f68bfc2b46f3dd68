#include "server/http_server.hpp"

#include "server/byte_range.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <netdb.h>
#include <poll.h>
#include <strings.h>
#include <sys/socket.h>
#include <unistd.h>

namespace hocurve::server {
namespace {

thread_local int t_socket = -1;
thread_local bool t_close_after = false;
thread_local std::string t_hidden_range;  // the Range value kept from the library, this request

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

/// If a header line (without its '\n') names Range with a value cpp-httplib refuses, keeps the
/// value in t_hidden_range and returns true. Name and value are cut as the library cuts them: the
/// name up to ':', blanks around the value.
bool hide_refused_range(const char* line, size_t size) {
  static const char name[] = "range:";
  if (size < sizeof name - 1 || strncasecmp(line, name, sizeof name - 1) != 0) return false;
  size_t b = sizeof name - 1, e = size;
  while (b < e && (line[b] == ' ' || line[b] == '\t')) ++b;
  while (e > b && (line[e - 1] == ' ' || line[e - 1] == '\t' || line[e - 1] == '\r')) --e;
  std::string value(line + b, e - b);
  if (!httplib_refuses_range(value)) return false;
  if (t_hidden_range.empty()) t_hidden_range = std::move(value);
  return true;
}

/// The socket of one connection, for all its requests: bytes read past the end of one request
/// stay in `buf_` for the next (cpp-httplib's SocketStream is made anew per request and loses them).
class ConnectionStream : public httplib::Stream {
 public:
  ConnectionStream(int sock, int read_ms, int write_ms) : sock_(sock), read_ms_(read_ms), write_ms_(write_ms) {}

  bool buffered() const { return pos_ < end_; }

  /// Called before each request. Its head is then handed out a whole line at a time, less the
  /// Range headers that cpp-httplib refuses: the library parses Range before any handler runs and
  /// answers such a value 416 on every route, its body unread, where RFC 9110 says to ignore it.
  void begin_request() {
    t_hidden_range.clear();
    in_head_ = true;
    line_end_ = pos_;
  }

  bool is_readable() const override { return buffered() || socket_readable(); }

  /// Writable unless reset: a client that only shut down its sending side still reads the answer.
  bool is_writable() const override {
    const short r = poll_one(sock_, POLLOUT, write_ms_);
    return (r & POLLOUT) && !(r & (POLLERR | POLLHUP));
  }

  ssize_t read(char* ptr, size_t size) override {
    while (in_head_ && pos_ == line_end_) next_head_line();
    if (!buffered()) {
      if (!is_readable()) return -1;
      if (size >= sizeof buf_) return recv_some(ptr, size);
      const ssize_t n = recv_some(buf_, sizeof buf_);
      if (n <= 0) return n;
      pos_ = 0;
      end_ = (size_t)n;
    }
    const size_t n = std::min(size, (in_head_ ? line_end_ : end_) - pos_);  // a head line at a time
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
  bool socket_readable() const { return poll_one(sock_, POLLIN, read_ms_) & (POLLIN | POLLHUP | POLLERR); }

  /// Brings the head's next line whole into the buffer and drops it if it is a refused Range
  /// header. The head ends at its empty line, or where a line outgrows the buffer or the client
  /// stops sending: the library then answers the rest as it would have (400, or nothing).
  void next_head_line() {
    std::memmove(buf_, buf_ + pos_, end_ - pos_);
    end_ -= pos_;
    pos_ = 0;
    const char* nl;
    while (!(nl = (const char*)std::memchr(buf_, '\n', end_)) && end_ < sizeof buf_ && socket_readable()) {
      const ssize_t n = recv_some(buf_ + end_, sizeof buf_ - end_);
      if (n <= 0) break;
      end_ += (size_t)n;
    }
    const size_t size = nl ? (size_t)(nl - buf_) : 0;
    if (!nl || size == 0 || (size == 1 && buf_[0] == '\r')) {
      in_head_ = false;
      return;
    }
    line_end_ = size + 1;
    if (hide_refused_range(buf_, size)) pos_ = line_end_;  // as if it had never been sent
  }

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
  char buf_[8192 + 2];  // room for the longest header line the library accepts (8 KiB and CRLF)
  size_t pos_ = 0, end_ = 0;
  bool in_head_ = false;
  size_t line_end_ = 0;  // in the head: where the line being handed out ends
};

}  // namespace

int current_connection_socket() { return t_socket; }

void close_connection_after_response() { t_close_after = true; }

std::string range_header(const httplib::Request& req) {
  return req.has_header("Range") ? req.get_header_value("Range") : t_hidden_range;
}

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
    strm.begin_request();
    bool closed = false;
    ret = process_request(strm, left == 1, closed, nullptr);
    if (!ret || closed || t_close_after) break;
  }
  t_socket = -1;
  t_close_after = false;
  t_hidden_range.clear();
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
