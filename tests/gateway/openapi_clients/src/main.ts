// Moves demo and kemar through the client @hey-api/openapi-ts generated from the gateway's /openapi.json
// (into ./client), and reads their ports back as typed objects: node dist/main.js GATEWAY_URL TOKEN
import { client } from './client/client.gen';
import {
  demoGotoPosition, demoReadMobile, kemarHoming, kemarMoveAbsolutePosition, kemarReadCurrentState, waitRequest,
} from './client/sdk.gen';

async function ended(module: string, id: string): Promise<string> {
  const status = await waitRequest({ path: { module, rqst: id }, query: { timeout: 120 } });
  if (!status.data) throw new Error(`wait ${id}: ${JSON.stringify(status.error)}`);
  return status.data.status;
}

async function main(): Promise<void> {
  const [gateway, token] = process.argv.slice(2);
  client.setConfig({ baseUrl: gateway, auth: () => token });
  const goto = await demoGotoPosition({ body: { posRef: 0.5 } });
  if (!goto.data) throw new Error(`GotoPosition: ${JSON.stringify(goto.error)}`);
  const gotoEnded = await ended('demo', goto.data.id);
  const mobile = await demoReadMobile();
  const homing = await kemarHoming();
  if (!homing.data) throw new Error(`Homing: ${JSON.stringify(homing.error)}`);
  const homingEnded = await ended('kemar', homing.data.id);
  const move = await kemarMoveAbsolutePosition({ body: { target: 20 } });
  if (!move.data) throw new Error(`MoveAbsolutePosition: ${JSON.stringify(move.error)}`);
  const moveEnded = await ended('kemar', move.data.id);
  const head = await kemarReadCurrentState();
  // Typed all the way: these are numbers (or null for a NaN), not any.
  const position: number | null | undefined = mobile.data?.Mobile.position;
  const azimuth: number | null | undefined = head.data?.currentState.position;
  console.log(JSON.stringify({ gotoEnded, homingEnded, moveEnded, position, azimuth }));
}

main().catch((error) => { console.error(error); process.exit(1); });
