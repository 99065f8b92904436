"""Bags: reading, salvaging and writing rosbag2 bags (mcap or sqlite3) with ``rosbags``.

- :mod:`.reader`: a bag's raw messages in time order, surviving damage (``replay``);
- :mod:`.salvage`: what a damaged storage file still holds, and what it lost;
- :mod:`.records`: the topic and raw-message records the readers return;
- :mod:`.recording`: a bench recording in SI units (channels, series);
- :mod:`.bench`: the bench bag schema decoded into a recording, and its ground truth;
- :mod:`.writer`: the writer of every bag the project writes, and its type store.
"""
