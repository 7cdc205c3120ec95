#!/usr/bin/env python3
"""A stand-in for the lab's traffic-light server (code/vtl_ws/vtl.py), for the real-time tests.

Written from the protocol alone (reference section 7), not from our tlserver, so that a real-time
run is tried against a server the simulator's code had no hand in:
  /vtl/request "<car><intersection>": granted ("<car>1" on /vtl/response) if the intersection's
      slot is empty or already held by that car, else denied ("<car>0");
  /vtl/free "<car>": empties every slot the car holds.
Two slots (intersections 0 and 1), no queue, no lease; QoS 1. Anything else is logged and ignored.

Usage: vtl_standin.py HOST PORT [USERNAME PASSWORD]
Prints "ready" once subscribed, and one line per message it handles. Needs paho-mqtt (Debian:
python3-paho-mqtt); works with paho-mqtt 1.x and 2.x. Stops on SIGTERM or SIGINT.
"""

import signal
import sys

import paho.mqtt.client as mqtt

REQUEST = "/vtl/request"
FREE = "/vtl/free"
RESPONSE = "/vtl/response"
INTERSECTIONS = (0, 1)

slots = {i: None for i in INTERSECTIONS}  # intersection -> the car holding it, or None


def log(line):
    print(line, flush=True)


def on_connect(client, userdata, flags, rc, properties=None):
    if rc != 0:
        log(f"connection refused: {rc}")
        return
    client.subscribe([(REQUEST, 1), (FREE, 1)])


def on_subscribe(client, userdata, mid, granted_qos, properties=None):
    log("ready")


def on_message(client, userdata, message):
    payload = message.payload.decode("ascii", errors="replace")
    if message.topic == REQUEST and len(payload) == 2 and payload.isdigit():
        car, intersection = payload[0], int(payload[1])
        if intersection not in slots:
            log(f"request {payload}: no intersection {intersection}, ignored")
            return
        granted = slots[intersection] in (None, car)
        if granted:
            slots[intersection] = car
        client.publish(RESPONSE, car + ("1" if granted else "0"), qos=1)
        log(f"request {payload}: {'granted' if granted else 'denied'}")
    elif message.topic == FREE and len(payload) == 1 and payload.isdigit():
        for intersection, holder in slots.items():
            if holder == payload:
                slots[intersection] = None
        log(f"free {payload}: slots {slots}")
    else:
        log(f"ignored {message.topic} {payload!r}")


def main():
    if len(sys.argv) not in (3, 5):
        sys.exit(__doc__)
    host, port = sys.argv[1], int(sys.argv[2])
    try:  # paho-mqtt 2.x asks which callback signatures we use
        client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION1, client_id="vtl-standin")
    except AttributeError:
        client = mqtt.Client(client_id="vtl-standin")
    if len(sys.argv) == 5:
        client.username_pw_set(sys.argv[3], sys.argv[4])
    client.on_connect = on_connect
    client.on_subscribe = on_subscribe
    client.on_message = on_message
    signal.signal(signal.SIGTERM, lambda *_: client.disconnect())
    signal.signal(signal.SIGINT, lambda *_: client.disconnect())
    client.connect(host, port, keepalive=10)
    client.loop_forever()


if __name__ == "__main__":
    main()
