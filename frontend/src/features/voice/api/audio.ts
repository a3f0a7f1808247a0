import { apiPost } from '@/lib/api-client';

export interface AudioTurn {
  transcript: string;
  confidence: number | null;
  recognizer: string;
  heard: 'stop' | 'motion' | 'answer' | 'other';
  rejected: string | null;
  read_back: boolean;
  reply: string;
  route: string;
  mission_id: string | null;
}

/** One push-to-talk recording → the brain's speech input → a normal turn. */
export function sendAudio(recording: Blob): Promise<AudioTurn> {
  return apiPost<AudioTurn>('/api/chat/audio', recording, recording.type || 'audio/webm');
}
