"""Moves demo and kemar through the client openapi-python-client generated (importable as ``client``).

Run as ``python _generated_python_client.py GATEWAY_URL TOKEN`` with the generated package on the path;
prints what it read back, as JSON.
"""

import json
import sys

from client import AuthenticatedClient
from client.api.demo import demo_goto_position, demo_read_mobile
from client.api.kemar import kemar_homing, kemar_move_absolute_position, kemar_read_current_state
from client.api.modules import wait_request
from client.models import DemoGotoPositionInput, DemoState, KemarMoveAbsolutePositionInput, KemarState


def ended(api: AuthenticatedClient, module: str, request_id: str) -> str:
    status = wait_request.sync(client=api, module=module, rqst=request_id, timeout=120)
    return str(status.status.value)


def main() -> None:
    api = AuthenticatedClient(base_url=sys.argv[1], token=sys.argv[2], raise_on_unexpected_status=True)
    goto = demo_goto_position.sync(client=api, body=DemoGotoPositionInput(pos_ref=0.5))
    goto_ended = ended(api, "demo", goto.id)
    mobile = demo_read_mobile.sync(client=api).mobile
    homing = kemar_homing.sync(client=api)
    homing_ended = ended(api, "kemar", homing.id)
    move = kemar_move_absolute_position.sync(client=api, body=KemarMoveAbsolutePositionInput(target=20))
    move_ended = ended(api, "kemar", move.id)
    head = kemar_read_current_state.sync(client=api).current_state
    assert isinstance(mobile, DemoState) and isinstance(head, KemarState)  # typed models, not dicts
    print(json.dumps({"gotoEnded": goto_ended, "homingEnded": homing_ended, "moveEnded": move_ended,
                      "position": mobile.position, "azimuth": head.position}))


main()
