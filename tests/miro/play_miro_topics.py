#!/usr/bin/python3
"""Plays a recorded MiRo's frames as the robot's own ROS 1 topics, through a real master.

The frames are an image folder with its frames.jsonl index (what `robot-agent run
--record-frames DIR` and `sim_agent run --record-frames DIR` write): each frame goes out as
a sensor_msgs/CompressedImage on the left or right camera's topic, after the robot's state
at that frame as sensor_msgs/JointState (the neck's tilt, lift, yaw and pitch) and
geometry_msgs/Pose2D, every message stamped now. Needs Debian's python3-rospy,
python3-sensor-msgs and python3-geometry-msgs.

    play_miro_topics.py DIR [--rate HZ] [--loops N] [--wrong-type]

--rate: frames a second per camera (default 5). --loops: times through the folder (0:
for ever). --wrong-type: the joints topic carries std_msgs/String instead (a publisher the
agent must refuse).
"""
import argparse
import json
import os
import sys

import rospy
from geometry_msgs.msg import Pose2D
from sensor_msgs.msg import CompressedImage, JointState
from std_msgs.msg import String


def main():
    p = argparse.ArgumentParser()
    p.add_argument("dir")
    p.add_argument("--rate", type=float, default=5.0)
    p.add_argument("--loops", type=int, default=1)
    p.add_argument("--wrong-type", action="store_true")
    args = p.parse_args()
    with open(os.path.join(args.dir, "frames.jsonl")) as f:
        records = [json.loads(line) for line in f if line.strip()]
    images = {}
    for r in records:
        with open(os.path.join(args.dir, r["file"]), "rb") as f:
            images[r["file"]] = f.read()
    rospy.init_node("miro_player", disable_signals=True)
    cams = {
        "left": rospy.Publisher("/miro/sensors/caml/compressed", CompressedImage, queue_size=4),
        "right": rospy.Publisher("/miro/sensors/camr/compressed", CompressedImage, queue_size=4),
    }
    if args.wrong_type:
        joints = rospy.Publisher("/miro/sensors/kinematic_joints", String, queue_size=4)
    else:
        joints = rospy.Publisher("/miro/sensors/kinematic_joints", JointState, queue_size=4)
    pose = rospy.Publisher("/miro/sensors/body_pose", Pose2D, queue_size=4)
    # Subscribers find the publishers through the master: give them a moment.
    rospy.sleep(1.0)
    period = 1.0 / (2.0 * args.rate)
    sent = 0
    loop = 0
    while not rospy.is_shutdown() and (args.loops == 0 or loop < args.loops):
        for r in records:
            if rospy.is_shutdown():
                break
            now = rospy.Time.now()
            head = r["head"]
            if args.wrong_type:
                joints.publish(String(data="not joints"))
            else:
                js = JointState()
                js.header.stamp = now
                js.name = ["tilt", "lift", "yaw", "pitch"]
                js.position = [0.0, head["lift_rad"], head["yaw_rad"], head["pitch_rad"]]
                joints.publish(js)
            pose.publish(Pose2D(x=r["pose"]["x_m"], y=r["pose"]["y_m"], theta=r["pose"]["theta_rad"]))
            img = CompressedImage()
            img.header.stamp = now
            img.format = "png" if r["file"].endswith(".png") else "jpeg"
            img.data = images[r["file"]]
            cams[r["camera"]].publish(img)
            sent += 1
            rospy.sleep(period)
        loop += 1
    print("sent %d frames" % sent, flush=True)


if __name__ == "__main__":
    sys.exit(main())
