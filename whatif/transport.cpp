#include "whatif/transport.h"

#include <chrono>
#include <deque>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "whatif/jobs.h"

namespace rectify::whatif
{
  namespace fs = std::filesystem;

  namespace
  {
    constexpr int tag_request = 1, tag_job = 2;

    /// Waits without spinning a core: an idle rank must not take the CPU a
    /// working one on the same core needs (and rank 0's scheduler shares a core).
    void pause_briefly() { std::this_thread::sleep_for(std::chrono::milliseconds(2)); }

    void send_string(MPI_Comm comm, int dest, int tag, const std::string &s)
    {
      MPI_Send(s.data(), static_cast<int>(s.size()), MPI_CHAR, dest, tag, comm);
    }

    std::string receive_string(MPI_Comm comm, MPI_Status status)
    {
      int n = 0;
      MPI_Get_count(&status, MPI_CHAR, &n);
      std::string s(static_cast<std::size_t>(n), '\0');
      MPI_Recv(s.data(), n, MPI_CHAR, status.MPI_SOURCE, status.MPI_TAG, comm, MPI_STATUS_IGNORE);
      return s;
    }

    std::string wait_for_string(MPI_Comm comm, int source, int tag)
    {
      for (;;)
        {
          int        flag = 0;
          MPI_Status status;
          MPI_Iprobe(source, tag, comm, &flag, &status);
          if (flag)
            return receive_string(comm, status);
          pause_briefly();
        }
    }

    void wait(MPI_Request &request)
    {
      for (int done = 0;;)
        {
          MPI_Test(&request, &done, MPI_STATUS_IGNORE);
          if (done)
            return;
          pause_briefly();
        }
    }

    std::string broadcast_string(MPI_Comm group, std::string s)
    {
      int size = 1;
      MPI_Comm_size(group, &size);
      if (size == 1)
        return s;
      long        n = static_cast<long>(s.size());
      MPI_Request r;
      MPI_Ibcast(&n, 1, MPI_LONG, 0, group, &r);
      wait(r);
      s.resize(static_cast<std::size_t>(n));
      MPI_Ibcast(s.data(), static_cast<int>(n), MPI_CHAR, 0, group, &r);
      wait(r);
      return s;
    }

  } // namespace

  /// Rank 0's scheduler thread: answers every group leader's request with
  /// the next ready job, holds it while none is ready but some run, and
  /// stops it ("") when nothing is left.
  void schedule(Scheduler &scheduler, MPI_Comm comm, unsigned n_groups)
  {
    std::deque<int> waiting;
    unsigned        active = n_groups;
    while (active > 0)
      {
        int        flag = 0;
        MPI_Status status;
        MPI_Iprobe(MPI_ANY_SOURCE, tag_request, comm, &flag, &status);
        if (flag)
          {
            const std::string report = receive_string(comm, status);
            if (!report.empty())
              {
                const auto r = nlohmann::json::parse(report);
                scheduler.finish(status.MPI_SOURCE, r.at("ok").get<bool>(), r.at("reason").get<std::string>(),
                                 r.at("wall_s").get<double>());
              }
            waiting.push_back(status.MPI_SOURCE);
          }
        while (!waiting.empty())
          {
            if (const auto job = scheduler.next(waiting.front()))
              send_string(comm, waiting.front(), tag_job, job->to_text());
            else if (scheduler.n_running() == 0)
              {
                send_string(comm, waiting.front(), tag_job, "");
                --active;
              }
            else
              break;
            waiting.pop_front();
          }
        if (!flag)
          pause_briefly();
      }
  }

  /// A group's loop: its leader asks rank 0 for a job, the group runs it.
  void serve(const BatchSettings &bs, const std::vector<DesignCase> &designs, const Paths &paths, MPI_Comm sched,
             MPI_Comm group_comm)
  {
    const auto group  = stokes::MpiSession::on(group_comm);
    const bool leader = group.rank() == 0;
    std::string report;
    for (;;)
      {
        std::string text;
        if (leader)
          {
            send_string(sched, 0, tag_request, report);
            text = wait_for_string(sched, 0, tag_job);
          }
        text = broadcast_string(group_comm, text);
        if (text.empty())
          return;
        const Job   job = Job::from_text(text);
        const auto  t   = Clock::now();
        int         ok  = 1;
        std::string reason;
        try
          {
            run_job(job, bs, designs, paths, group);
          }
        catch (const std::exception &e)
          {
            ok     = 0;
            reason = e.what();
          }
        int all_ok = ok;
        MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, group_comm);
        if (!all_ok && ok)
          reason = "failed on another process of its group";
        report = nlohmann::json{{"ok", all_ok != 0}, {"reason", reason}, {"wall_s", seconds_since(t)}}.dump();
      }
  }
} // namespace rectify::whatif
